# yaml-cpp for the aarch64 cross build (see toolchain/aarch64-linux-gnu.cmake):
# the arm64 shared library of libyaml-cpp0.7:arm64 and the architecture-
# independent headers of the host's libyaml-cpp-dev (same version, 0.7.0).
set(_springbok_yaml_lib /usr/lib/aarch64-linux-gnu/libyaml-cpp.so.0.7)
if(NOT EXISTS "${_springbok_yaml_lib}" OR NOT EXISTS /usr/include/yaml-cpp/yaml.h)
  set(yaml-cpp_FOUND FALSE)
  set(yaml-cpp_NOT_FOUND_MESSAGE "needs libyaml-cpp0.7:arm64 and libyaml-cpp-dev (headers)")
  return()
endif()
if(NOT TARGET yaml-cpp)
  add_library(yaml-cpp SHARED IMPORTED)
  set_target_properties(yaml-cpp PROPERTIES
    IMPORTED_LOCATION "${_springbok_yaml_lib}"
    INTERFACE_INCLUDE_DIRECTORIES /usr/include)
endif()
if(NOT TARGET yaml-cpp::yaml-cpp)
  add_library(yaml-cpp::yaml-cpp INTERFACE IMPORTED)
  set_target_properties(yaml-cpp::yaml-cpp PROPERTIES INTERFACE_LINK_LIBRARIES yaml-cpp)
endif()
set(YAML_CPP_LIBRARIES yaml-cpp)
set(yaml-cpp_FOUND TRUE)
