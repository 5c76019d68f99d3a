# Cross build for the rig's board (arm64 Linux) with Debian's multiarch
# toolchain: g++-aarch64-linux-gnu and the :arm64 -dev packages that
# `scripts/setup.sh arm64` installs. Tests run under qemu-aarch64 (qemu-user),
# named here because binfmt may not be registered.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# Multiarch: libraries and their CMake/pkg-config files under
# /usr/lib/aarch64-linux-gnu, headers shared in /usr/include.
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
# libc6:arm64 puts the dynamic loader where qemu-aarch64 looks for it.
find_program(PIEZO_QEMU_AARCH64 qemu-aarch64 REQUIRED)
set(CMAKE_CROSSCOMPILING_EMULATOR "${PIEZO_QEMU_AARCH64}")
