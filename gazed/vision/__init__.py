"""Vision: frame sources, ego-motion, detectors (flow, pyramid, background), candidates, and
the `vision` process's work per frame (`stage`).

seed 000 §2 (foveal normal flow with ego-rotation compensation), seed 004 §2-3 and §5 (motion
energy pyramid, coarse-to-fine search, compensating the head's rotation), seed 003 §IV
(background subtraction); DESIGN §6.
"""
