// tinygltf's one implementation in psrig (its header is header-only): no
// stb image codecs, psrig reads and writes the PNGs itself.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
