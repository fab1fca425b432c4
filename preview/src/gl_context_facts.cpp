#include "gl_context_facts.h"

#include <EGL/egl.h>
#include <GLES3/gl3.h>
#include <cstdio>

namespace psrig::preview {

std::string egl_error(const std::string& what) {
  char code[16];
  std::snprintf(code, sizeof code, "0x%04X", eglGetError());
  return what + " failed (EGL error " + code + ")";
}

std::string gl_description() {
  const auto text = [](GLenum name) {
    const auto* value = reinterpret_cast<const char*>(glGetString(name));
    return std::string(value ? value : "?");
  };
  return text(GL_RENDERER) + ", " + text(GL_VERSION);
}

std::string_view egl_extension_list(EGLDisplay display) {
  const char* list = eglQueryString(display, EGL_EXTENSIONS);
  return list != nullptr ? list : "";
}

std::string gl_extension_list() {
  GLint count = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &count);
  std::string list;
  for (GLint i = 0; i < count; ++i) {
    if (i > 0) list += ' ';
    list += reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
  }
  return list;
}

}  // namespace psrig::preview
