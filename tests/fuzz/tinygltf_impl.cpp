// tinygltf's implementation, compiled with the fuzzers' instrumentation (the library links
// Debian's libtinygltf, built from this same header). Images are never decoded (gltf.cpp sets
// its own image loader), so stb_image is left out.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
