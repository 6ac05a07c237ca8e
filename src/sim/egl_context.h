// EGL for offscreen OpenGL without a display server, shared by sim::OffscreenRenderer and perception::DepthCamera.
#pragma once

#include <EGL/egl.h>

#include <string>
#include <vector>

namespace rmpmarl::sim::internal {

/// EGL displays to try, best first: a GPU device if one is exposed, Mesa's surfaceless platform, the default display.
std::vector<EGLDisplay> CandidateEglDisplays();

/// makes a desktop-OpenGL context (RGBA8, 24-bit depth, 8-bit stencil) current on `display`; EGL_NO_CONTEXT and why
/// when it cannot. The display stays initialised either way: an EGL display is one per process, shared by every
/// renderer and depth camera, and terminating it would destroy the others' contexts.
EGLContext MakeCurrentEglContext(EGLDisplay display, std::string* why_not);

}  // namespace rmpmarl::sim::internal
