# The aarch64 cross build with clang 14 instead of GCC (tools/check-isa-matrix):
# the same sysroot, libraries and qemu as aarch64-linux-gnu.cmake; clang finds the
# cross libstdc++ of g++-aarch64-linux-gnu through --target.
include("${CMAKE_CURRENT_LIST_DIR}/aarch64-linux-gnu.cmake")
set(CMAKE_C_COMPILER clang-14)
set(CMAKE_CXX_COMPILER clang++-14)
set(CMAKE_C_COMPILER_TARGET aarch64-linux-gnu)
set(CMAKE_CXX_COMPILER_TARGET aarch64-linux-gnu)
