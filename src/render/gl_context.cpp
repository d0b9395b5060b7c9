// EGL without a window: EGL_MESA_platform_surfaceless (Mesa picks llvmpipe when there is no GPU)
// or EGL_EXT_platform_device for a chosen device; an OpenGL 4.5 core context with no surface
// (EGL_KHR_surfaceless_context), so all drawing goes to framebuffer objects.
#include "render/gl_context.hpp"

#include <utility>
#include <vector>

namespace duolod::render {
namespace {
using core::Error;

std::string eglErrorName() {
  EGLint code = eglGetError();
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "EGL error 0x%04x", code);
  return buffer;
}

}  // namespace

core::Result<GlContext> GlContext::create(const ContextOptions& options) {
  GlContext context;
  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  std::string extensions = client_extensions ? client_extensions : "";
  if (options.device < 0) {
    if (extensions.find("EGL_MESA_platform_surfaceless") == std::string::npos)
      return Error{
          "EGL has no EGL_MESA_platform_surfaceless: install Mesa (libegl-mesa0, "
          "libgl1-mesa-dri) or choose an EGL device by index (ContextOptions::device)"};
    context.display_ = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY,
                                                nullptr);
  } else {
    if (extensions.find("EGL_EXT_device_enumeration") == std::string::npos)
      return Error{"EGL cannot enumerate devices (no EGL_EXT_device_enumeration)"};
    EGLint count = 0;
    eglQueryDevicesEXT(0, nullptr, &count);
    std::vector<EGLDeviceEXT> devices(count);
    eglQueryDevicesEXT(count, devices.data(), &count);
    if (options.device >= count)
      return Error{"EGL device " + std::to_string(options.device) + " requested but only " +
                   std::to_string(count) + " exist"};
    context.display_ =
        eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[options.device], nullptr);
  }
  if (context.display_ == EGL_NO_DISPLAY) return Error{"no EGL display (" + eglErrorName() + ")"};
  EGLint major = 0, minor = 0;
  if (!eglInitialize(context.display_, &major, &minor))
    return Error{"eglInitialize failed (" + eglErrorName() + ")"};
  if (auto made = context.makeContext(EGL_NO_CONTEXT); !made) return made.error();
  return context;
}

core::Result<GlContext> GlContext::createSharing(const GlContext& share) {
  return createSharing(share.display_, share.context_);
}

core::Result<GlContext> GlContext::createSharing(EGLDisplay display, EGLContext share) {
  if (share == EGL_NO_CONTEXT) return Error{"render: no GL context to share"};
  GlContext context;
  context.display_ = display;
  if (auto made = context.makeContext(share); !made) return made.error();
  return context;
}

// The OpenGL 4.5 core context on display_, sharing `share`'s objects (EGL_NO_CONTEXT: none),
// current on the calling thread.
core::Status GlContext::makeContext(EGLContext share) {
  // The client API is per thread: a thread of its own starts with OpenGL ES.
  if (!eglBindAPI(EGL_OPENGL_API)) return Error{"EGL cannot bind OpenGL (" + eglErrorName() + ")"};
  const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                               EGL_CONTEXT_OPENGL_PROFILE_MASK,
                               EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  context_ = eglCreateContext(display_, EGL_NO_CONFIG_KHR, share, attributes);
  if (context_ == EGL_NO_CONTEXT)
    return Error{"cannot create an OpenGL 4.5 core context (" + eglErrorName() + ")"};
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    return Error{"eglMakeCurrent failed (" + eglErrorName() + ")"};
  if (epoxy_gl_version() < 45)
    return Error{"OpenGL 4.5 is required; the context has " +
                 std::to_string(epoxy_gl_version() / 10) + "." +
                 std::to_string(epoxy_gl_version() % 10)};
  return core::okStatus();
}

GlContext& GlContext::operator=(GlContext&& other) noexcept {
  std::swap(display_, other.display_);
  std::swap(context_, other.context_);
  return *this;
}

core::Status GlContext::makeCurrent() const {
  if (context_ == EGL_NO_CONTEXT) return Error{"render: no GL context"};
  if (eglGetCurrentContext() == context_) return core::okStatus();
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    return Error{"render: cannot make the renderer's GL context current on this thread (" +
                 eglErrorName() + "; a Renderer is used by one thread at a time)"};
  return core::okStatus();
}

GlContext::~GlContext() {
  if (display_ != EGL_NO_DISPLAY) {
    // Released only where it is current: another Renderer's context stays as it is.
    if (eglGetCurrentContext() == context_)
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
    // No eglTerminate: Mesa would unload its driver, and leak checkers could no longer name the
    // driver's process-lifetime allocations. The display is reused by the next context.
    eglReleaseThread();
  }
}

std::string GlContext::description() const {
  auto text = [](GLenum name) {
    const GLubyte* s = glGetString(name);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  return text(GL_RENDERER) + ", OpenGL " + text(GL_VERSION);
}

}  // namespace duolod::render
