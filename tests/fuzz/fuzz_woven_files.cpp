// The neural woven BSDF's two binary files, as the trainer and the runtime
// read them: the input's first byte picks which (even: a data set,
// `psrig-woven-dataset/1`; odd: network weights, `psrig-woven-net/1`), the
// rest becomes the file, through read_woven_dataset() or
// WovenNetwork::load(). The magic is put in front when the input lacks it,
// so that the fuzzer spends its time past it.
//
// Besides crashes and sanitizer reports: an accepted data set's textures
// are T*T*3 floats each and its queries name its materials; accepted
// weights pass check_woven_network() and decode a query (the runtime's
// promise that a loaded network runs).

#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "fuzz_support.h"
#include "psrig/cloth/woven_network.h"

namespace {

constexpr std::string_view kDatasetMagic = "psrig-woven-dataset/1\n";
constexpr std::string_view kNetworkMagic = "psrig-woven-net/1\n";

[[noreturn]] void broken(const char* what) {
  std::fprintf(stderr, "fuzz_woven_files: %s\n", what);
  std::abort();
}

void check_dataset(const std::filesystem::path& file) {
  auto dataset = psrig::cloth::read_woven_dataset(file);
  if (!dataset) {
    (void)dataset.error().describe();
    return;
  }
  for (const auto& material : dataset->materials) {
    const auto texels = static_cast<std::size_t>(material.texture_size) * material.texture_size * 3;
    if (material.normal.size() != texels || material.orientation.size() != texels) {
      broken("an accepted material's textures are not T*T*3 floats");
    }
  }
  for (const auto& query : dataset->queries) {
    if (query.material >= dataset->materials.size()) broken("an accepted query names no material");
  }
}

void check_network(const std::filesystem::path& file) {
  // A 2 x 2 repeat of flat warp, for the features of a network that takes them.
  auto flat_material = [] {
    psrig::cloth::WovenMaterialSample material;
    material.texture_size = 2;
    for (int texel = 0; texel < 4; ++texel) {
      material.normal.insert(material.normal.end(), {0.0F, 0.0F, 1.0F});
      material.orientation.insert(material.orientation.end(), {0.0F, 1.0F, 0.0F});
    }
    return material;
  };
  auto network = psrig::cloth::WovenNetwork::load(file);
  if (!network) {
    (void)network.error().describe();
    return;
  }
  if (!psrig::cloth::check_woven_network(network->weights()))
    broken("accepted weights fail the check");
  const psrig::cloth::WovenDecoderMaterial material = network->prepare(
      std::vector<float>(static_cast<std::size_t>(network->shape().latent_size), 0.5F),
      flat_material());
  (void)network->decode(material, {0.3F, 0.6F, 1.0F, {0.0F, 0.6F, 0.8F}, {0.6F, 0.0F, 0.8F}});
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  psrig::fuzz::quiet_logs();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool dataset = data[0] % 2 == 0;
  const std::string_view magic = dataset ? kDatasetMagic : kNetworkMagic;
  std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  if (bytes.compare(0, magic.size(), magic) != 0) bytes.insert(0, magic);
  static const auto file = psrig::fuzz::scratch_directory() / "woven.bin";
  psrig::fuzz::write_file(file, bytes);
  if (dataset) {
    check_dataset(file);
  } else {
    check_network(file);
  }
  return 0;
}
