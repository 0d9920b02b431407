// EGL device choice and context lifetime for the headless renderer.
#include "egl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

namespace {

constexpr EGLint kMaxDevices = 16;

// llvmpipe: rasterising threads overlap its single-threaded vertex stage; two a core drew the
// sample 15% faster than one a core (one run: 291 against 340 ms). A user's setting wins.
void default_llvmpipe_threads() {
  if (std::getenv("LP_NUM_THREADS")) return;
  const unsigned threads = std::min(32u, 2 * std::max(1u, std::thread::hardware_concurrency()));
  setenv("LP_NUM_THREADS", std::to_string(threads).c_str(), 0);
}

// Displays to try, best first: hardware devices, then Mesa's software device, then Mesa's
// surfaceless platform. `tried` says what was found, for the error message.
std::vector<EGLDisplay> candidate_displays(std::string* tried) {
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto query_device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
  std::vector<EGLDisplay> candidates;
  if (get_platform_display && query_devices) {
    EGLDeviceEXT devices[kMaxDevices];
    EGLint count = 0;
    if (query_devices(kMaxDevices, devices, &count)) {
      std::vector<std::pair<bool, EGLDeviceEXT>> order;  // (is software, device)
      for (EGLint i = 0; i < count; ++i) {
        const char* ext = query_device_string ? query_device_string(devices[i], EGL_EXTENSIONS) : nullptr;
        order.push_back({ext && std::strstr(ext, "EGL_MESA_device_software"), devices[i]});
      }
      std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (auto& [software, device] : order) candidates.push_back(get_platform_display(EGL_PLATFORM_DEVICE_EXT, device, nullptr));
    }
    *tried += std::to_string(count) + " EGL device(s)";
  }
  if (get_platform_display) candidates.push_back(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr));
  return candidates;
}

// An OpenGL 4.5 core context on an initialised display, made current; EGL_NO_CONTEXT when
// the display has none.
EGLContext core_context(EGLDisplay display) {
  if (!eglBindAPI(EGL_OPENGL_API)) return EGL_NO_CONTEXT;
  const EGLint config_attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  eglChooseConfig(display, config_attributes, &config, 1, &configs);
  const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                       EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext context = eglCreateContext(display, configs ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, context_attributes);
  if (context == EGL_NO_CONTEXT) return EGL_NO_CONTEXT;
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    eglDestroyContext(display, context);
    return EGL_NO_CONTEXT;
  }
  return context;
}

}  // namespace

EglContext::EglContext() {
  default_llvmpipe_threads();
  std::string tried;
  for (EGLDisplay display : candidate_displays(&tried)) {
    if (display == EGL_NO_DISPLAY) continue;
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) continue;
    EGLContext context = core_context(display);
    if (context == EGL_NO_CONTEXT) {
      tried += "; a display without an OpenGL 4.5 core context";
      eglTerminate(display);
      continue;
    }
    display_ = display;
    context_ = context;
    return;
  }
  throw RenderError("no EGL device with OpenGL 4.5 core could be opened (tried " + (tried.empty() ? std::string("none") : tried) +
                    " and Mesa's surfaceless platform); install libegl-mesa0 and libgl1-mesa-dri, or the NVIDIA driver's EGL");
}

// The display is not terminated: other threads' contexts (the server's render workers) share
// it, and eglTerminate would mark theirs for deletion. It stays initialised to exit, as the
// server and `render` keep theirs (see RenderPool::run). Destroying the context alone gives
// back what Mesa holds for it, the storage of deleted framebuffers included.
EglContext::~EglContext() {
  if (!display_) return;
  if (eglGetCurrentContext() == context_) eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_) eglDestroyContext(display_, context_);
}

}  // namespace tetrascope::renderer
