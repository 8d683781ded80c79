# weft_module(<target> INTERFACE <.cppm...> [PRIVATE_MODULES <.cppm...>] SOURCES <.cpp...> LINK <targets...>)
# One folder = one C++20 module = one library target. INTERFACE: the primary interface unit
# and its interface partitions (installed); PRIVATE_MODULES: implementation partitions that
# only the module's own .cpp files import (not installed).
# Shared libraries by default (WEFT_SHARED_LIBS): a plugin loaded at run time (weft --plugin)
# links the same libweft_*.so files as the program that loads it, so the process holds one
# copy of each -- one pass-type and feature registry, one logger, one set of shader overrides.
function(weft_module target)
  cmake_parse_arguments(ARG "" "" "INTERFACE;PRIVATE_MODULES;SOURCES;LINK;PRIVATE_LINK" ${ARGN})
  if(WEFT_SHARED_LIBS)
    add_library(${target} SHARED)
  else()
    add_library(${target} STATIC)
  endif()
  add_library(weft::${target} ALIAS ${target})
  target_sources(${target}
    PUBLIC FILE_SET CXX_MODULES BASE_DIRS ${CMAKE_CURRENT_SOURCE_DIR} FILES ${ARG_INTERFACE})
  if(ARG_PRIVATE_MODULES)
    target_sources(${target}
      PRIVATE FILE_SET private_modules TYPE CXX_MODULES BASE_DIRS ${CMAKE_CURRENT_SOURCE_DIR} FILES ${ARG_PRIVATE_MODULES})
  endif()
  if(ARG_SOURCES)
    target_sources(${target} PRIVATE ${ARG_SOURCES})
  endif()
  target_compile_features(${target} PUBLIC cxx_std_23)
  target_link_libraries(${target} PUBLIC ${ARG_LINK} PRIVATE ${ARG_PRIVATE_LINK})
  weft_warnings(${target})
  set_property(GLOBAL APPEND PROPERTY WEFT_LIBRARIES ${target})
endfunction()
