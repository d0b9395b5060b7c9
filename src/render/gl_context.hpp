// The EGL context behind the Renderer: surfaceless Mesa (llvmpipe without a GPU) or an EGL device.
#pragma once

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <string>

#include "duolod/core.hpp"
#include "duolod/render.hpp"

namespace duolod::render {

class GlContext {
 public:
  static core::Result<GlContext> create(const ContextOptions& options);
  // A context on `share`'s display that shares its objects (programs, buffers, textures; not
  // framebuffers or vertex arrays), made current on the calling thread: for a second thread that
  // draws with the first context's objects.
  static core::Result<GlContext> createSharing(const GlContext& share);
  static core::Result<GlContext> createSharing(EGLDisplay display, EGLContext share);
  GlContext() = default;
  GlContext(GlContext&& other) noexcept { *this = std::move(other); }
  GlContext& operator=(GlContext&& other) noexcept;
  ~GlContext();

  std::string description() const;
  // Makes this context current on the calling thread unless it is already (one thread-local
  // query: cheap). Another Renderer, or the caller's own GL context, may have been made current
  // since. Fails when the context is current on another thread.
  core::Status makeCurrent() const;
  EGLContext handle() const { return context_; }
  EGLDisplay display() const { return display_; }

 private:
  core::Status makeContext(EGLContext share);

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
};

}  // namespace duolod::render
