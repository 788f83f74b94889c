"""argand.media: a frame's pixels as files people open.

frame_files     EXR with every AOV, PNG preview, JSON figures (OpenImageIO)
gif             each frame's GIF fragment, spliced into the animation
video           the MP4 animation (PyAV)
atlas           the sheet of a (σ, δ) grid, one cell a frame, angles as π fractions
contact_sheet   presets by δ, for the README
"""
