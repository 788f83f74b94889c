"""argand.media: a frame's pixels as files people open.

frame_files     EXR with every AOV, PNG preview, JSON figures (OpenImageIO)
gif             each frame's GIF fragment, spliced into the animation
video           the MP4 animation (PyAV)
contact_sheet   pictures in rows and columns, one cell each (the atlas and the README's presets by δ)
atlas           the labelled sheet of a (σ, δ) grid, one cell a frame, angles as π fractions
"""
