# Kernel variants per instruction-set level (firmware/isa/include/springbok/isa/isa.hpp).
#
# SPRINGBOK_ISA_VARIANT_LEVELS: the -march levels compiled besides the build's own. The
# portable x86-64 build has x86-64-v3 and x86-64-v4 (SPRINGBOK_ISA_DISPATCH, on by
# default there); any other build, and the sanitizer builds, none: their kernels are the
# build's own.
#
# springbok_isa_variants(<lib> NAMESPACE <ns> SOURCES <src>... [OBJECTS_OF <lib2>...] LINK <dep>...)
#   compiles SOURCES once per level (with -march=<level>, the level's namespace macro
#   SPRINGBOK_ISA_NAMESPACE, e.g. isa_x86_64_v3, and the baseline's Eigen layout), links them
#   (and the same level's objects of each OBJECTS_OF library) into one relocatable object,
#   renames every symbol and COMDAT group it defines (suffix .<lib>_<level namespace>) but
#   the entry points (<ns>::<level namespace>::...) and Eigen's malloc-trap flag (one per
#   process), and makes them local: no template or inline function of one level (or of
#   another library's copy) can replace another's at the final link. The object goes into <lib>.
set(SPRINGBOK_ISA_BASELINE_NAME "${SPRINGBOK_ARCH}")
if(SPRINGBOK_ARCH STREQUAL "portable")
  string(REGEX REPLACE "^-march=" "" SPRINGBOK_ISA_BASELINE_NAME "${_springbok_march}")
  list(GET SPRINGBOK_ISA_BASELINE_NAME 0 SPRINGBOK_ISA_BASELINE_NAME)
endif()
set(_springbok_dispatch_default OFF)
if(SPRINGBOK_ARCH STREQUAL "portable" AND CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$"
   AND NOT SPRINGBOK_SANITIZE)
  set(_springbok_dispatch_default ON)
endif()
option(SPRINGBOK_ISA_DISPATCH "Compile the hot kernels for x86-64-v3 and -v4 as well, chosen at start-up"
       ${_springbok_dispatch_default})
set(SPRINGBOK_ISA_VARIANT_LEVELS "")
if(SPRINGBOK_ISA_DISPATCH)
  set(SPRINGBOK_ISA_VARIANT_LEVELS x86-64-v3 x86-64-v4)
  find_program(SPRINGBOK_OBJCOPY NAMES objcopy REQUIRED)
  find_program(SPRINGBOK_NM NAMES nm REQUIRED)
  find_program(SPRINGBOK_LD NAMES ld REQUIRED)
endif()
message(STATUS "springbok: kernel variants: ${SPRINGBOK_ISA_VARIANT_LEVELS}")

function(springbok_isa_variants lib)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "NAMESPACE" "SOURCES;OBJECTS_OF;LINK")
  foreach(level IN LISTS SPRINGBOK_ISA_VARIANT_LEVELS)
    string(MAKE_C_IDENTIFIER "isa_${level}" level_ns)
    set(objects_lib ${lib}_${level_ns})
    add_library(${objects_lib} OBJECT ${arg_SOURCES})
    set_target_properties(${objects_lib} PROPERTIES SPRINGBOK_ISA_LEVEL ${level})
    target_include_directories(${objects_lib} PRIVATE "$<TARGET_PROPERTY:${lib},INCLUDE_DIRECTORIES>")
    target_link_libraries(${objects_lib} PRIVATE ${arg_LINK})
    target_compile_definitions(${objects_lib} PRIVATE SPRINGBOK_ISA_NAMESPACE=${level_ns}
                                                      EIGEN_MAX_STATIC_ALIGN_BYTES=16)
    if(level STREQUAL "x86-64-v4" AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU"
       AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
      target_compile_options(${objects_lib} PRIVATE
        -include "${PROJECT_SOURCE_DIR}/toolchain/include/springbok/gcc12_avx512_intrinsics.hpp")
    endif()
    set(objects "$<TARGET_OBJECTS:${objects_lib}>")
    set(depends ${objects_lib})
    foreach(other IN LISTS arg_OBJECTS_OF)
      list(APPEND objects "$<TARGET_OBJECTS:${other}_${level_ns}>")
      list(APPEND depends ${other}_${level_ns})
    endforeach()
    # The entry points: <NAMESPACE>::<level namespace>::..., mangled.
    set(keep "_ZN")
    string(REPLACE "::" ";" parts "${arg_NAMESPACE}::${level_ns}")
    foreach(part IN LISTS parts)
      string(LENGTH "${part}" n)
      string(APPEND keep "${n}${part}")
    endforeach()
    set(out "${CMAKE_CURRENT_BINARY_DIR}/${lib}_${level_ns}.o")
    add_custom_command(
      OUTPUT "${out}"
      COMMAND "${PROJECT_SOURCE_DIR}/toolchain/isa_variant_link" "${SPRINGBOK_LD}" "${SPRINGBOK_NM}"
              "${SPRINGBOK_OBJCOPY}" "${out}" "${keep}" ".${lib}_${level_ns}" ${objects}
      DEPENDS ${depends} ${objects} "${PROJECT_SOURCE_DIR}/toolchain/isa_variant_link"
      COMMENT "springbok: ${lib}'s kernels for ${level}"
      COMMAND_EXPAND_LISTS VERBATIM)
    set_source_files_properties("${out}" PROPERTIES EXTERNAL_OBJECT TRUE GENERATED TRUE)
    target_sources(${lib} PRIVATE "${out}")
  endforeach()
endfunction()
