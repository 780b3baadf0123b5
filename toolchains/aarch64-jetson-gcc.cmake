# Cross toolchain for NVIDIA Jetson Xavier NX (Carmel cores, ARMv8.2-A) with Debian's
# g++-aarch64-linux-gnu. GCC 12 has no -mcpu=carmel, so we name the architecture instead.
#
# Against a real Jetson root filesystem (copied or mounted from the device):
#   cmake --preset aarch64 -DCMAKE_SYSROOT=/path/to/jetson-rootfs
# Without a sysroot, Debian's multiarch cross libraries under /usr/aarch64-linux-gnu are used and
# tests run on this host through qemu-aarch64.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_CXX_FLAGS_INIT "-march=armv8.2-a+fp16+crypto")
set(CMAKE_C_FLAGS_INIT "-march=armv8.2-a+fp16+crypto")

if(CMAKE_SYSROOT)
  set(CMAKE_FIND_ROOT_PATH ${CMAKE_SYSROOT})
  set(_dynamap_qemu_root ${CMAKE_SYSROOT})
else()
  set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
  set(_dynamap_qemu_root /usr/aarch64-linux-gnu)
  # Eigen is header-only and architecture-independent: use the host's copy.
  set(Eigen3_DIR /usr/share/eigen3/cmake CACHE PATH "Eigen3 config (host, header-only)")
endif()
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

find_program(DYNAMAP_QEMU qemu-aarch64)
if(DYNAMAP_QEMU)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${DYNAMAP_QEMU} -L ${_dynamap_qemu_root})
endif()
