# Cross build for 64-bit ARM Linux with Debian's cross compiler, tests run
# under qemu-user. Packages (tools/setup): g++-aarch64-linux-gnu,
# qemu-user-static, and the arm64 multiarch libraries (dpkg --add-architecture
# arm64): libgtest-dev:arm64 libgmock-dev:arm64 libtinyxml2-dev:arm64
# libyaml-cpp0.7:arm64. Header-only dependencies (Eigen, CLI11) are shared.
#   cmake --preset aarch64 && cmake --build --preset aarch64 && ctest --preset aarch64
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Debian multiarch: arm64 libraries and their CMake packages live in
# /usr/lib/aarch64-linux-gnu; find_package looks there instead of x86_64-linux-gnu.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)

find_program(SPRINGBOK_QEMU_AARCH64 qemu-aarch64-static REQUIRED)
# The arm64 loader and libraries are installed in / by multiarch (libc6:arm64).
set(CMAKE_CROSSCOMPILING_EMULATOR "${SPRINGBOK_QEMU_AARCH64}")

# libyaml-cpp-dev is not Multi-Arch: same (its :arm64 package would remove the
# amd64 one), so yaml-cpp comes from a small package file here: the arm64
# runtime library (libyaml-cpp0.7:arm64) with the shared headers.
list(PREPEND CMAKE_PREFIX_PATH "${CMAKE_CURRENT_LIST_DIR}/aarch64-linux-gnu")
