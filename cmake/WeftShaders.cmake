# weft_add_shaders(<target> <glsl files...>): compiles GLSL to SPIR-V at build time with
# glslangValidator and embeds each as `std::span<const uint32_t> weft::shaders::<name>()`,
# so built-in passes ship no loose files and shader errors fail the build, not the frame.
# Each accessor first asks weft/shader_overrides.h for a replacement (shader hot reload in
# weft view) and registers its source file, so a program can find and recompile it.
#
# Installed with weft (find_package(weft) includes it), so a plugin built out of tree compiles
# its shaders the same way: WEFT_SHADER_INCLUDE_DIR is weft's shaders/ folder (frame.glsl),
# in the source tree or installed under share/weft/shaders.
if(NOT WEFT_SHADER_INCLUDE_DIR)
  set(WEFT_SHADER_INCLUDE_DIR "${CMAKE_CURRENT_LIST_DIR}/../shaders")
endif()
function(weft_add_shaders target)
  if(NOT GLSLANG_VALIDATOR)
    find_program(GLSLANG_VALIDATOR glslangValidator REQUIRED)
  endif()
  set(generated_headers)
  set(gen_dir ${CMAKE_CURRENT_BINARY_DIR}/shaders)
  file(MAKE_DIRECTORY ${gen_dir})
  set(decls "")
  set(protos "")
  set(defs "")
  set(registrations "")
  set(include_dirs "${WEFT_SHADER_INCLUDE_DIR};${CMAKE_CURRENT_SOURCE_DIR}")
  foreach(src ${ARGN})
    get_filename_component(abs ${src} ABSOLUTE)
    get_filename_component(fname ${src} NAME)
    string(MAKE_C_IDENTIFIER ${fname} ident)
    set(header ${gen_dir}/${fname}.spv.h)
    # --depfile lists every #include, so editing an included .glsl rebuilds the SPIR-V.
    add_custom_command(
      OUTPUT ${header}
      COMMAND ${GLSLANG_VALIDATOR} --quiet -V --target-env vulkan1.3 -I${WEFT_SHADER_INCLUDE_DIR}
              -I${CMAKE_CURRENT_SOURCE_DIR} --vn spv_${ident} --depfile ${header}.d -o ${header} ${abs}
      DEPENDS ${abs}
      DEPFILE ${header}.d
      COMMENT "glslang ${fname}"
      VERBATIM)
    list(APPEND generated_headers ${header})
    string(APPEND decls "#include \"${fname}.spv.h\"\n")
    # Hidden: a plugin's accessor of the same file name (outline.frag) must not bind to a
    # built-in pass's in another shared library, nor the other way round.
    string(APPEND defs "[[gnu::visibility(\"hidden\")]] std::span<const std::uint32_t> ${ident}() {\n"
                       "  if (auto o = find_override(\"${fname}\"); !o.empty()) return o;\n"
                       "  return spv_${ident};\n}\n")
    string(APPEND registrations "  register_source(\"${fname}\", \"${abs}\", \"${include_dirs}\");\n")
    string(APPEND protos "[[gnu::visibility(\"hidden\")]] std::span<const std::uint32_t> ${ident}();\n")
  endforeach()
  string(MAKE_C_IDENTIFIER ${target} target_ident)
  set(cpp ${gen_dir}/${target}_shaders.cpp)
  file(WRITE ${cpp}.in "#include <cstdint>\n#include <span>\n#include \"weft/shader_overrides.h\"\n${decls}"
                      "namespace weft::shaders {\n${defs}\nnamespace {\n"
                      "[[maybe_unused]] const bool registered_${target_ident} = [] {\n${registrations}  return true;\n}();\n}\n}\n")
  configure_file(${cpp}.in ${cpp} COPYONLY)
  # <target>_shaders.h declares the accessors for the target's own sources.
  set(h ${gen_dir}/${target}_shaders.h)
  file(WRITE ${h}.in "#pragma once\n#include <cstdint>\n#include <span>\nnamespace weft::shaders {\n${protos}}\n")
  configure_file(${h}.in ${h} COPYONLY)
  target_sources(${target} PRIVATE ${cpp} ${generated_headers})
  target_include_directories(${target} PRIVATE ${gen_dir})
  if(TARGET weft_core)  # weft/shader_overrides.h
    target_link_libraries(${target} PRIVATE weft_core)
  else()
    target_link_libraries(${target} PRIVATE weft::weft_core)
  endif()
endfunction()
