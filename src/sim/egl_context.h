// EGL for offscreen OpenGL without a display server, shared by sim::OffscreenRenderer and perception::DepthCamera.
#pragma once

#include <EGL/egl.h>

#include <string>

namespace rmpmarl::sim::internal {

/// makes a desktop-OpenGL context (RGBA8, 24-bit depth, 8-bit stencil) current on `display`; EGL_NO_CONTEXT and why
/// when it cannot. The display stays initialised either way: an EGL display is one per process, shared by every
/// renderer and depth camera, and terminating it would destroy the others' contexts.
EGLContext MakeCurrentEglContext(EGLDisplay display, std::string* why_not);

/// An EGL display with a context current on it.
struct EglContext {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

/// MakeCurrentEglContext on the first display that takes one, best first: a GPU device if one is exposed, Mesa's
/// surfaceless platform, the default display. When none does: context EGL_NO_CONTEXT, and `why_not` gets every
/// display's reason.
EglContext MakeCurrentEglContextOnFirstDisplay(std::string* why_not);

}  // namespace rmpmarl::sim::internal
