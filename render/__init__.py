"""Offscreen rendering of virtual objects with moderngl (EGL) and compositing
onto video frames. Imports ``geometry`` only."""
