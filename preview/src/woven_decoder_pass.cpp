#include "psrig/preview/woven_decoder_pass.h"

#include <GLES3/gl3.h>
#include <algorithm>
#include <optional>
#include <string>

#include "gl_program.h"

namespace psrig::preview {

struct WovenDecoderPass::Gl {
  std::optional<GlProgram> program;
  GLuint weights = 0;  // the texture or the uniform buffer
  GLuint array = 0;
  GLuint queries[3] = {0, 0, 0};  // footprints, incoming, outgoing
  GLuint features = 0;            // the material's footprint features' table
  bool uniform_block = false;
  int fusion_width = 0, angular_width = 0, footprint_features = 0;
  ~Gl() {
    if (uniform_block) {
      glDeleteBuffers(1, &weights);
    } else {
      glDeleteTextures(1, &weights);
    }
    glDeleteTextures(3, queries);
    glDeleteTextures(1, &features);
    glDeleteVertexArrays(1, &array);
  }
};

namespace {

constexpr int kWeightTextureWidth = 1024;  // texels a row, the texture fallback's
constexpr GLuint kWeightsBinding = 0;
constexpr int kFeaturesUnit = 4;

// The decoder's layers as the shader reads them: one flat array of vec4s,
// each layer's 4x4 blocks (mat4 columns: column j of block (g, k) holds
// rows 4g..4g+3 of input 4k+j), then its biases four to a vec4; fuse1 only
// its footprint columns, blobs and features (the latent's are folded into
// the material's bias).
struct WeightVectors {
  std::vector<cv::Vec4f> vectors;
  std::string defines;
};

void add_layer(WeightVectors& out, const std::string& name, const cloth::DenseLayer& layer,
               int first_input, int inputs, bool bias) {
  const int outputs4 = (layer.outputs + 3) / 4, inputs4 = (inputs + 3) / 4;
  auto weight = [&](int o, int i) {
    return o < layer.outputs && i < inputs
               ? layer.weight[static_cast<std::size_t>(o) * layer.inputs + first_input + i]
               : 0.0F;
  };
  out.defines += "#define " + name + "_W " + std::to_string(out.vectors.size()) + "\n";
  for (int g = 0; g < outputs4; ++g) {
    for (int k = 0; k < inputs4; ++k) {
      for (int j = 0; j < 4; ++j) {
        out.vectors.emplace_back(weight(4 * g, 4 * k + j), weight(4 * g + 1, 4 * k + j),
                                 weight(4 * g + 2, 4 * k + j), weight(4 * g + 3, 4 * k + j));
      }
    }
  }
  if (!bias) return;
  out.defines += "#define " + name + "_B " + std::to_string(out.vectors.size()) + "\n";
  for (int g = 0; g < outputs4; ++g) {
    cv::Vec4f four;
    for (int r = 0; r < 4; ++r)
      four[r] = 4 * g + r < layer.outputs ? layer.bias[4 * g + r] : 0.0F;
    out.vectors.push_back(four);
  }
}

WeightVectors decoder_vectors(const cloth::WovenNetworkWeights& w) {
  const cloth::WovenNetworkShape& s = w.shape;
  WeightVectors out;
  add_layer(out, "FUSE1", w.fuse1, s.latent_size, cloth::decoder_footprint_inputs(s), false);
  add_layer(out, "FUSE2", w.fuse2, 0, w.fuse2.inputs, true);
  add_layer(out, "ANG_IN", w.ang_in, 0, w.ang_in.inputs, true);
  add_layer(out, "ANG_RES1", w.ang_res1, 0, w.ang_res1.inputs, true);
  add_layer(out, "ANG_RES2", w.ang_res2, 0, w.ang_res2.inputs, true);
  add_layer(out, "ANG_MID", w.ang_mid, 0, w.ang_mid.inputs, true);
  add_layer(out, "ANG_OUT", w.ang_out, 0, w.ang_out.inputs, true);
  out.defines += "#define FUSION4 " + std::to_string(s.fusion_width / 4) + "\n#define ANGULAR4 " +
                 std::to_string(s.angular_width / 4) + "\n#define JOINED4 " +
                 std::to_string(s.fusion_width / 4 + 2) + "\n#define BLOB_BINS " +
                 std::to_string(s.blob_bins) + "\n#define BLOB4 " +
                 std::to_string(cloth::decoder_blob_inputs(s) / 4) + "\n#define FEATURE4 " +
                 std::to_string(s.footprint_features / 4) + "\n#define WEIGHT_VECTORS " +
                 std::to_string(out.vectors.size()) + "\n#define WEIGHT_TEXTURE_WIDTH " +
                 std::to_string(kWeightTextureWidth) + "\n";
  return out;
}

// Whether the context takes the weights as one uniform block (GLES 3.0
// promises only 16 KB; the default decoder needs about 26).
bool fits_a_uniform_block(std::size_t vectors) {
  GLint largest = 0;
  glGetIntegerv(GL_MAX_UNIFORM_BLOCK_SIZE, &largest);
  return static_cast<std::size_t>(largest) >= vectors * sizeof(cv::Vec4f);
}

// The footprint features' table (cloth::WovenFootprintFeatures::table) as
// woven_decoder.frag reads it: corner (i, j)'s 12 sums in texels 3i..3i+2
// of row j.
cv::Mat feature_texels(const cloth::WovenFootprintFeatures& features) {
  static_assert(cloth::woven_footprint_feature_count == 12);
  // A material prepared without textures: a one-texel repeat of nothing,
  // zeros as the CPU decoder gives.
  if (features.empty()) return {2, 6, CV_32FC4, cv::Scalar::all(0)};
  const int corners = features.texture_size() + 1;
  cv::Mat texels(corners, 3 * corners, CV_32FC4);
  std::copy(features.table().begin(), features.table().end(), texels.ptr<float>());
  return texels;
}

// A float image as an RGBA32F texture, read by texelFetch (no filtering).
void upload_float_texture(GLuint texture, const cv::Mat& rgba) {
  glBindTexture(GL_TEXTURE_2D, texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, rgba.cols, rgba.rows, 0, GL_RGBA, GL_FLOAT, rgba.data);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
}

}  // namespace

cv::Vec3f woven_radiance(const cloth::WovenComponents& c, const WovenColours& colours,
                         float cos_incoming) {
  const cv::Vec3f f = colours.kd_warp * c.c_warp + colours.kd_weft * c.c_weft +
                      colours.ks_warp * c.s_warp + colours.ks_weft * c.s_weft;
  // f carries eq. (3)'s cosine already (woven_aggregate.h): E f, and
  // nothing from a light below the cloth.
  return cos_incoming > 0 ? f * colours.irradiance : cv::Vec3f(0, 0, 0);
}

Result<std::unique_ptr<WovenDecoderPass>> WovenDecoderPass::create(
    const cloth::WovenNetwork& network, WovenWeightStorage storage, WovenQuerySource source) {
  const WeightVectors weights = decoder_vectors(network.weights());
  const bool uniform_block = storage == WovenWeightStorage::uniform_block;
  if (uniform_block && !fits_a_uniform_block(weights.vectors.size())) {
    return std::unexpected(internal_error(
        "the woven decoder's weights (" + std::to_string(weights.vectors.size() * 16) +
        " bytes) are more than this context's uniform blocks take: use the texture"));
  }
  const bool mesh = source == WovenQuerySource::mesh;
  const std::string defines = weights.defines +
                              (uniform_block ? "#define WEIGHTS_IN_UNIFORM_BLOCK 1\n" : "") +
                              (mesh ? "#define QUERIES_FROM_MESH 1\n" : "");
  auto program = GlProgram::build(mesh ? shaders::woven_far_vert : shaders::woven_decoder_vert,
                                  shaders::woven_decoder_frag, defines);
  if (!program) return std::unexpected(program.error());
  std::unique_ptr<WovenDecoderPass> pass(new WovenDecoderPass);
  pass->gl_ = std::make_unique<Gl>();
  Gl& gl = *pass->gl_;
  gl.program = std::move(*program);
  gl.fusion_width = network.shape().fusion_width;
  gl.angular_width = network.shape().angular_width;
  gl.footprint_features = network.shape().footprint_features;
  gl.uniform_block = uniform_block;
  glGenVertexArrays(1, &gl.array);
  glGenTextures(3, gl.queries);
  glGenTextures(1, &gl.features);
  if (uniform_block) {
    glGenBuffers(1, &gl.weights);
    glBindBuffer(GL_UNIFORM_BUFFER, gl.weights);
    glBufferData(GL_UNIFORM_BUFFER,
                 static_cast<GLsizeiptr>(weights.vectors.size() * sizeof(cv::Vec4f)),
                 weights.vectors.data(), GL_STATIC_DRAW);
    glBindBuffer(GL_UNIFORM_BUFFER, 0);
    gl.program->use();
    const GLuint block = glGetUniformBlockIndex(gl.program->id(), "WovenWeights");
    glUniformBlockBinding(gl.program->id(), block, kWeightsBinding);
  } else {
    glGenTextures(1, &gl.weights);
    const int rows =
        static_cast<int>((weights.vectors.size() + kWeightTextureWidth - 1) / kWeightTextureWidth);
    cv::Mat texels(rows, kWeightTextureWidth, CV_32FC4, cv::Scalar::all(0));
    std::copy(weights.vectors.begin(), weights.vectors.end(), texels.ptr<cv::Vec4f>());
    upload_float_texture(gl.weights, texels);
  }
  if (const GLenum error = glGetError(); error != GL_NO_ERROR) {
    return std::unexpected(
        internal_error("the woven decoder's weights (" + std::to_string(weights.vectors.size()) +
                       " vec4s) were refused: GL error " + std::to_string(error)));
  }
  return pass;
}

bool WovenDecoderPass::weights_in_uniform_block() const {
  return gl_->uniform_block;
}

WovenDecoderPass::~WovenDecoderPass() = default;

void WovenDecoderPass::set_material(const cloth::WovenDecoderMaterial& material) {
  gl_->program->use();
  glUniform4fv(gl_->program->uniform("u_fusion_bias"), gl_->fusion_width / 4,
               material.fusion_bias.data());
  if (gl_->footprint_features > 0) {
    upload_float_texture(gl_->features, feature_texels(material.features));
  }
}

Status WovenDecoderPass::set_queries(const cv::Mat& footprints, const cv::Mat& incoming,
                                     const cv::Mat& outgoing) {
  const cv::Mat* images[3] = {&footprints, &incoming, &outgoing};
  for (int i = 0; i < 3; ++i) {
    if (images[i]->type() != CV_32FC3 || images[i]->size() != footprints.size()) {
      return std::unexpected(bad_input({}, "",
                                       "the woven decoder's queries are three CV_32FC3 "
                                       "images of one size"));
    }
    cv::Mat rgba;
    cv::Mat channels[4];
    cv::split(*images[i], channels);
    channels[3] = cv::Mat::zeros(images[i]->size(), CV_32F);
    cv::merge(channels, 4, rgba);
    upload_float_texture(gl_->queries[i], rgba);
  }
  return {};
}

int WovenDecoderPass::uniform(const std::string& name) const {
  return gl_->program->uniform(name);
}

void WovenDecoderPass::draw(const WovenColours& colours) const {
  use(colours);
  const GlProgram& program = *gl_->program;
  const char* names[3] = {"u_footprints", "u_incoming", "u_outgoing"};
  for (int unit = 0; unit < 3; ++unit) {
    glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
    glBindTexture(GL_TEXTURE_2D, gl_->queries[unit]);
    glUniform1i(program.uniform(names[unit]), unit);
  }
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glBindVertexArray(gl_->array);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glActiveTexture(GL_TEXTURE0);
}

void WovenDecoderPass::use(const WovenColours& colours) const {
  const GlProgram& program = *gl_->program;
  program.use();
  if (gl_->uniform_block) {
    glBindBufferBase(GL_UNIFORM_BUFFER, kWeightsBinding, gl_->weights);
  } else {
    glActiveTexture(GL_TEXTURE3);
    glBindTexture(GL_TEXTURE_2D, gl_->weights);
    glUniform1i(program.uniform("u_weights"), 3);
  }
  glUniform3fv(program.uniform("u_kd_warp"), 1, colours.kd_warp.val);
  glUniform3fv(program.uniform("u_kd_weft"), 1, colours.kd_weft.val);
  glUniform3fv(program.uniform("u_ks_warp"), 1, colours.ks_warp.val);
  glUniform3fv(program.uniform("u_ks_weft"), 1, colours.ks_weft.val);
  glUniform1f(program.uniform("u_irradiance"), colours.irradiance);
  glUniform1i(program.uniform("u_fusion4"), gl_->fusion_width / 4);
  glUniform1i(program.uniform("u_angular4"), gl_->angular_width / 4);
  if (gl_->footprint_features > 0) {
    glUniform1i(program.uniform("u_feature_groups"), gl_->footprint_features / 4);
    glActiveTexture(GL_TEXTURE0 + kFeaturesUnit);
    glBindTexture(GL_TEXTURE_2D, gl_->features);
    glUniform1i(program.uniform("u_features"), kFeaturesUnit);
  }
  glActiveTexture(GL_TEXTURE0);
}

}  // namespace psrig::preview
