// An offscreen OpenGL context through EGL, shared by sim::OffscreenRenderer and perception::DepthCamera.
#include "rmpmarl/sim/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <fmt/format.h>

#include <vector>

namespace rmpmarl::sim {
namespace {

// EGL displays to try, best first: a GPU device if one is exposed, Mesa's surfaceless platform, the default display.
std::vector<EGLDisplay> CandidateDisplays() {
  std::vector<EGLDisplay> candidates;
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display != nullptr) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    if (query_devices != nullptr) {
      EGLDeviceEXT devices[8];
      EGLint count = 0;
      if (query_devices(8, devices, &count)) {
        for (EGLint i = 0; i < count; ++i) {
          candidates.push_back(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr));
        }
      }
    }
    candidates.push_back(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr));
  }
  candidates.push_back(eglGetDisplay(EGL_DEFAULT_DISPLAY));
  return candidates;
}

// a desktop-OpenGL context current on `display` (initialised here if it is not); EGL_NO_CONTEXT and why when it
// cannot be made
EGLContext MakeCurrentContext(EGLDisplay display, std::string* why_not) {
  EGLint major = 0, minor = 0;
  if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor)) {
    *why_not = fmt::format("EGL display cannot be initialised (EGL error 0x{:x})", eglGetError());
    return EGL_NO_CONTEXT;
  }
  const EGLint config_attributes[] = {EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_ALPHA_SIZE, 8,
                                      EGL_DEPTH_SIZE, 24, EGL_STENCIL_SIZE, 8, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                      EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config;
  EGLint num_configs = 0;
  if (!eglChooseConfig(display, config_attributes, &config, 1, &num_configs) || num_configs < 1) {
    *why_not = "EGL offers no OpenGL configuration with 24-bit depth";
  } else if (!eglBindAPI(EGL_OPENGL_API)) {
    *why_not = "EGL cannot bind the desktop OpenGL API";
  } else {
    EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, nullptr);
    if (context != EGL_NO_CONTEXT && eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) return context;
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    *why_not = fmt::format("EGL could not create/make current an OpenGL context (EGL error 0x{:x})", eglGetError());
  }
  return EGL_NO_CONTEXT;
}

}  // namespace

struct OffscreenGlContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

OffscreenGlContext::OffscreenGlContext() : impl_(std::make_unique<Impl>()) {}

std::unique_ptr<OffscreenGlContext> OffscreenGlContext::Create(std::string* why_not) {
  std::string reasons;
  for (EGLDisplay display : CandidateDisplays()) {
    std::string why;
    const EGLContext context = MakeCurrentContext(display, &why);
    if (context != EGL_NO_CONTEXT) {
      std::unique_ptr<OffscreenGlContext> gl(new OffscreenGlContext());
      gl->impl_->display = display;
      gl->impl_->context = context;
      return gl;
    }
    reasons += (reasons.empty() ? "" : "; ") + why;
  }
  *why_not = reasons.empty() ? "no EGL display found" : reasons;
  return nullptr;
}

OffscreenGlContext::~OffscreenGlContext() {
  if (impl_->context == EGL_NO_CONTEXT) return;
  if (IsCurrent()) eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(impl_->display, impl_->context);
}

bool OffscreenGlContext::IsCurrent() const {
  return impl_->context != EGL_NO_CONTEXT && eglGetCurrentContext() == impl_->context;
}

bool OffscreenGlContext::MakeCurrent(std::string* why_not) {
  if (eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context)) return true;
  const EGLint error = eglGetError();
  if (why_not != nullptr) *why_not = fmt::format("EGL error 0x{:x}", error);
  return false;
}

bool OffscreenGlContext::Remake(std::string* why_not) {
  // the old context died with its display's termination (another process-wide user): nothing of it to free
  impl_->context = MakeCurrentContext(impl_->display, why_not);
  return impl_->context != EGL_NO_CONTEXT;
}

}  // namespace rmpmarl::sim
