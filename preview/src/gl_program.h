#pragma once
// A linked GLSL program from two embedded shaders; compile and link
// errors come back with the shader's file name and GL's log.

#include <string>
#include <string_view>
#include <unordered_map>

#include <Eigen/Core>

#include "psrig/base/error.h"
#include "shader_sources.h"

namespace psrig::preview {

class GlProgram {
 public:
  // `defines` ("#define NAME 1\n" lines) go into both shaders right after
  // their #version line.
  [[nodiscard]] static Result<GlProgram> build(const shaders::ShaderSource& vertex,
                                               const shaders::ShaderSource& fragment,
                                               std::string_view defines = {});
  GlProgram(GlProgram&& other) noexcept;
  GlProgram& operator=(GlProgram&& other) noexcept;
  GlProgram(const GlProgram&) = delete;
  GlProgram& operator=(const GlProgram&) = delete;
  ~GlProgram();

  void use() const;
  // GL's name for it, for the calls this class does not wrap (uniform blocks).
  [[nodiscard]] unsigned id() const { return id_; }
  // -1 when the program has no such active uniform (GL then ignores the set).
  [[nodiscard]] int uniform(const std::string& name) const;

 private:
  GlProgram() = default;
  unsigned id_ = 0;
  mutable std::unordered_map<std::string, int> locations_;
};

// Sets a mat4 uniform of the program in use.
void set_matrix(int location, const Eigen::Matrix4f& matrix);

}  // namespace psrig::preview
