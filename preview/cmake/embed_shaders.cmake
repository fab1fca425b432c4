# Writes OUTPUT, a C++ file defining one psrig::preview::shaders::ShaderSource
# per file in SOURCES (a ;-list), named after the file: swatch.frag ->
# swatch_frag. Run by the build whenever a shader changes.
set(text "// Generated from preview/shaders by embed_shaders.cmake: edit the shaders, not this.\n")
string(APPEND text "#include \"shader_sources.h\"\n\nnamespace psrig::preview::shaders {\n")
foreach(source IN LISTS SOURCES)
  get_filename_component(name "${source}" NAME)
  string(REPLACE "." "_" symbol "${name}")
  file(READ "${source}" body)
  string(APPEND text "const ShaderSource ${symbol}{\"${name}\", R\"glsl(${body})glsl\"};\n")
endforeach()
string(APPEND text "}  // namespace psrig::preview::shaders\n")
file(WRITE "${OUTPUT}.tmp" "${text}")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.tmp")
