"""argand.frames: which frames a job or a CLI run asks for.

angles      angles as people write them (0.35, pi/9, 2*pi/3), and sweeps START:STOP:COUNT
defaults    a frame's size when a run gives none
frame_set   the (σ, δ) pairs of a run: a sweep, a grid sigmas x deltas, or the atlas, and the band rule
"""
