# Sourced by the build scripts (build.sh, asan.sh, tsan.sh, fuzz.sh): compile
# through ccache when it is installed and the caller chose no launcher. The
# cache is ccache's own (~/.cache/ccache); paths under the repository are
# hashed relative to it and the working directory is left out of the hash,
# so every clone and build directory on the machine shares its entries (a
# fresh clone's CI run compiles only what changed). Set
# CMAKE_CXX_COMPILER_LAUNCHER to another launcher, or to an empty string for
# none, to override. CMake reads the launcher when a build directory is
# first configured.
if [[ -z "${CMAKE_CXX_COMPILER_LAUNCHER+set}" ]] && command -v ccache >/dev/null 2>&1; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache
  export CCACHE_BASEDIR="$PWD"
  export CCACHE_NOHASHDIR=true
fi
