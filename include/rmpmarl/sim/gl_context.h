#pragma once
/// An offscreen OpenGL context for MuJoCo's renderer, made through EGL without a display server (a GPU device when one
/// is exposed, else Mesa's software rasteriser): sim::OffscreenRenderer and perception::DepthCamera each hold one.
/// EGL stays inside the sim module; this header names none of its types.
#include <memory>
#include <string>

namespace rmpmarl::sim {

class OffscreenGlContext {
 public:
  /// a desktop-OpenGL context (RGBA8, 24-bit depth, 8-bit stencil) current on this thread, on the first EGL display
  /// that takes one, best first: a GPU device, Mesa's surfaceless platform, the default display. nullptr when none
  /// does; *why_not then gives every display's reason.
  static std::unique_ptr<OffscreenGlContext> Create(std::string* why_not);
  /// destroys the context (made not current first). The display stays initialised: an EGL display is one per
  /// process, shared by every renderer and depth camera, and terminating it would destroy their contexts too.
  ~OffscreenGlContext();
  OffscreenGlContext(const OffscreenGlContext&) = delete;
  OffscreenGlContext& operator=(const OffscreenGlContext&) = delete;

  /// this context is the current one on this thread.
  bool IsCurrent() const;
  /// makes it current on this thread; false when EGL refuses (*why_not, when given, says the EGL error).
  bool MakeCurrent(std::string* why_not = nullptr);
  /// a new context on the same display, current, in place of one that has become unusable (its GL objects died with
  /// it); false and why when that fails too.
  bool Remake(std::string* why_not);

 private:
  OffscreenGlContext();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rmpmarl::sim
