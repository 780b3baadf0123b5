# Clang variant of the Xavier NX toolchain: clang knows the Carmel core by name.
# Uses Debian's aarch64 GCC cross runtime (libstdc++, crt files) under /usr/aarch64-linux-gnu.
# Point at a Jetson root filesystem with -DCMAKE_SYSROOT=/path/to/jetson-rootfs.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

set(CMAKE_C_COMPILER clang)
set(CMAKE_CXX_COMPILER clang++)
set(CMAKE_C_COMPILER_TARGET aarch64-linux-gnu)
set(CMAKE_CXX_COMPILER_TARGET aarch64-linux-gnu)
set(CMAKE_CXX_FLAGS_INIT "-mcpu=carmel")
set(CMAKE_C_FLAGS_INIT "-mcpu=carmel")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-fuse-ld=bfd")

if(CMAKE_SYSROOT)
  set(CMAKE_FIND_ROOT_PATH ${CMAKE_SYSROOT})
  set(_dynamap_qemu_root ${CMAKE_SYSROOT})
else()
  set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
  set(_dynamap_qemu_root /usr/aarch64-linux-gnu)
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
