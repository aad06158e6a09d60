"""Headless OpenGL context (moderngl over EGL) and the renderer's error."""

from __future__ import annotations

import logging
from typing import Any

from usdworld.errors import UsdWorldError

log = logging.getLogger(__name__)

#: Debian packages that provide EGL and the Mesa llvmpipe (CPU) OpenGL driver.
GL_PACKAGES = "libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libgbm1"
INSTALL_HINT = f"apt-get install -y --no-install-recommends {GL_PACKAGES}"
#: OpenGL 4.1: double-precision vertex attributes (the instanced draw places corners in double).
MIN_GL_VERSION = 410


class RenderError(UsdWorldError):
    """Headless OpenGL is unavailable or a render failed."""

    exit_code = 1


def create_context() -> Any:
    """A standalone moderngl context on EGL (no display needed).

    Raises:
        RenderError: moderngl is missing, or EGL / OpenGL 4.1 cannot start; the message
            says what to install.
    """
    try:
        import moderngl
    except ImportError as exc:
        raise RenderError(
            f"rendering needs the Python package moderngl ({exc}); run: pip install 'moderngl>=5.13'"
        ) from None
    try:
        ctx = moderngl.create_standalone_context(backend="egl", require=MIN_GL_VERSION)  # type: ignore[arg-type]
    except Exception as exc:  # noqa: BLE001  (glcontext raises plain Exceptions with the driver's text)
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise RenderError(
            f"headless OpenGL (EGL, GL >= 4.1) could not start ({reason}); install the Debian packages: {INSTALL_HINT}"
        ) from None
    log.debug("OpenGL context: %s, %s", ctx.info.get("GL_RENDERER"), ctx.info.get("GL_VERSION"))
    return ctx
