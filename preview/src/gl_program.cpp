#include "gl_program.h"

#include <GLES3/gl3.h>
#include <utility>

namespace psrig::preview {
namespace {

std::string info_log(GLuint object, bool is_program) {
  GLint length = 0;
  if (is_program)
    glGetProgramiv(object, GL_INFO_LOG_LENGTH, &length);
  else
    glGetShaderiv(object, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  if (is_program)
    glGetProgramInfoLog(object, length, nullptr, log.data());
  else
    glGetShaderInfoLog(object, length, nullptr, log.data());
  log.resize(log.find('\0') == std::string::npos ? log.size() : log.find('\0'));
  return log;
}

Result<GLuint> compile(GLenum stage, const shaders::ShaderSource& source,
                       std::string_view defines) {
  const GLuint shader = glCreateShader(stage);
  // After the first line: GLSL ES wants #version before anything else.
  const std::size_t first_line = source.text.find('\n') + 1;
  std::string text(source.text.substr(0, first_line));
  text += defines;
  text += "#line 2\n";  // keep the compiler's line numbers the file's
  text += source.text.substr(first_line);
  const char* data = text.data();
  const auto length = static_cast<GLint>(text.size());
  glShaderSource(shader, 1, &data, &length);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok == GL_TRUE) return shader;
  const std::string log = info_log(shader, false);
  glDeleteShader(shader);
  return std::unexpected(internal_error(std::string(source.name) + " does not compile: " + log));
}

}  // namespace

Result<GlProgram> GlProgram::build(const shaders::ShaderSource& vertex,
                                   const shaders::ShaderSource& fragment,
                                   std::string_view defines) {
  auto vertex_shader = compile(GL_VERTEX_SHADER, vertex, defines);
  if (!vertex_shader) return std::unexpected(vertex_shader.error());
  auto fragment_shader = compile(GL_FRAGMENT_SHADER, fragment, defines);
  if (!fragment_shader) {
    glDeleteShader(*vertex_shader);
    return std::unexpected(fragment_shader.error());
  }
  GlProgram program;
  program.id_ = glCreateProgram();
  glAttachShader(program.id_, *vertex_shader);
  glAttachShader(program.id_, *fragment_shader);
  glLinkProgram(program.id_);
  glDeleteShader(*vertex_shader);  // the program keeps them while it lives
  glDeleteShader(*fragment_shader);
  GLint ok = GL_FALSE;
  glGetProgramiv(program.id_, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE)
    return std::unexpected(internal_error(std::string(vertex.name) + " + " +
                                          std::string(fragment.name) +
                                          " do not link: " + info_log(program.id_, true)));
  return program;
}

GlProgram::GlProgram(GlProgram&& other) noexcept
    : id_(std::exchange(other.id_, 0)), locations_(std::move(other.locations_)) {}

GlProgram& GlProgram::operator=(GlProgram&& other) noexcept {
  std::swap(id_, other.id_);
  std::swap(locations_, other.locations_);
  return *this;
}

GlProgram::~GlProgram() {
  if (id_ != 0) glDeleteProgram(id_);
}

void GlProgram::use() const {
  glUseProgram(id_);
}

int GlProgram::uniform(const std::string& name) const {
  if (auto found = locations_.find(name); found != locations_.end()) return found->second;
  const int location = glGetUniformLocation(id_, name.c_str());
  locations_.emplace(name, location);
  return location;
}

void set_matrix(int location, const Eigen::Matrix4f& matrix) {
  glUniformMatrix4fv(location, 1, GL_FALSE, matrix.data());  // Eigen is column-major, as GL
}

}  // namespace psrig::preview
