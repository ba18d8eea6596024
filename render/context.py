"""The one place that creates OpenGL contexts: moderngl, standalone, EGL backend.

EGL needs no display server. On CPU-only machines it runs on Mesa's
``llvmpipe`` software rasteriser; on NVIDIA machines the driver's own
``libEGL`` (GLVND vendor ``libEGL_nvidia``) is picked up instead. Select a GPU
among several with the ``GLCONTEXT_DEVICE_INDEX`` environment variable (read
by glcontext), or point ``GLCONTEXT_LINUX_LIBEGL`` / ``GLCONTEXT_LINUX_LIBGL``
at specific libraries.

Mesa's llvmpipe rasterises on the thread that draws (``LP_NUM_THREADS=0``)
unless the environment says otherwise: arstream's renderers draw small
overlays beside other busy threads (decode, detection, x264), where
llvmpipe's own raster threads only add hand-overs (in ``arstream process`` at
720p, about 1 ms of CPU a frame; no slower alone, see bench/README.md).
Mesa reads the variable once per process, when the first context is made.

When no context can be made, :func:`create_context` raises
:class:`GLContextError` whose message names the missing library and the
Debian/Ubuntu packages that provide it.
"""

from __future__ import annotations

import ctypes.util
import os

import moderngl

__all__ = ["GLContextError", "create_context", "DEBIAN_PACKAGES", "describe_context"]

#: Debian/Ubuntu packages that provide EGL + OpenGL on a CPU (Mesa llvmpipe).
DEBIAN_PACKAGES = "libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri"

_INSTALL_HINT = f"install them with: sudo apt-get install -y {DEBIAN_PACKAGES}"


class GLContextError(RuntimeError):
    """No OpenGL context could be created (missing libEGL / libGL / Mesa driver)."""


def _find(name: str, env: str) -> str | None:
    path = os.environ.get(env)
    if path:
        return path if os.path.exists(path) else None
    return ctypes.util.find_library(name)


def create_context(require: int = 330) -> moderngl.Context:
    """Create a headless moderngl context with the EGL backend.

    Parameters
    ----------
    require : int
        Minimum OpenGL version as moderngl's code (330 = OpenGL 3.3 core).

    Returns
    -------
    moderngl.Context, current on the calling thread. Release it with
    ``ctx.release()`` when done.

    Raises
    ------
    GLContextError
        ``libEGL`` or ``libGL`` cannot be found, EGL finds no usable driver
        (Mesa's ``libEGL_mesa`` / ``swrast_dri`` missing), or the driver's
        OpenGL is older than ``require``. The message names the library and
        the Debian packages to install.
    """
    os.environ.setdefault("LP_NUM_THREADS", "0")  # llvmpipe: rasterise on the drawing thread (module docstring)
    libegl = _find("EGL", "GLCONTEXT_LINUX_LIBEGL")
    if libegl is None:
        raise GLContextError(
            "cannot create an OpenGL context: the EGL library (libEGL.so.1) was not found; "
            f"on CPU-only machines it comes with Mesa (llvmpipe) — {_INSTALL_HINT}"
        )
    libgl = _find("GL", "GLCONTEXT_LINUX_LIBGL")
    if libgl is None:
        raise GLContextError(
            "cannot create an OpenGL context: the OpenGL library (libGL.so.1) was not found; "
            f"it comes with libglvnd and Mesa — {_INSTALL_HINT}"
        )
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl", require=require, libegl=libegl, libgl=libgl)
    except Exception as exc:  # glcontext raises bare Exception for every failure
        raise GLContextError(
            f"cannot create an OpenGL {require // 100}.{require % 100 // 10} context with EGL "
            f"({libegl}, {libgl}): {str(exc).strip() or type(exc).__name__}; "
            "EGL found no usable driver — on CPU-only machines this needs Mesa's EGL vendor "
            f"library (libEGL_mesa.so.0) and the llvmpipe driver (swrast_dri.so): {_INSTALL_HINT}"
        ) from None
    return ctx


def describe_context(ctx: moderngl.Context) -> str:
    """One line naming the OpenGL renderer, e.g. ``'llvmpipe (LLVM 15.0.6, 256 bits), OpenGL 4.5 ...'``."""
    info = ctx.info
    return f"{info.get('GL_RENDERER', '?')}, OpenGL {info.get('GL_VERSION', '?')}, {ctx.max_samples}x MSAA max"
