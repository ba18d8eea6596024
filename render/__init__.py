"""Offscreen rendering of virtual objects with moderngl (EGL) and compositing
onto video frames. Imports ``geometry`` only."""

from render.compositor import Compositor
from render.context import GLContextError, create_context
from render.objects import Arrow, Billboard, DistanceRing, Logo, OffsideLine, Text, Text3D
from render.renderer import Overlay, Renderer
from render.scene import Scene, default_scene, load_scene

__all__ = [
    "Renderer",
    "Overlay",
    "Compositor",
    "Scene",
    "load_scene",
    "default_scene",
    "create_context",
    "GLContextError",
    "Logo",
    "OffsideLine",
    "DistanceRing",
    "Arrow",
    "Text",
    "Billboard",
    "Text3D",
]
