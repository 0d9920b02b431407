// A headless OpenGL 4.5 core context on EGL, current on the creating thread for its whole
// life. The one place EGL is used: its types stay in egl_context.cpp.
#pragma once

namespace tetrascope::renderer {

class EglContext {
 public:
  // Tries, in order: hardware EGL devices, Mesa's software device, Mesa's surfaceless
  // platform; makes the first OpenGL 4.5 core context it gets current. Throws RenderError
  // naming what was tried when none can be had.
  EglContext();
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

 private:
  void* display_ = nullptr;  // EGLDisplay
  void* context_ = nullptr;  // EGLContext
};

}  // namespace tetrascope::renderer
