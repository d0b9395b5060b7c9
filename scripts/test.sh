#!/usr/bin/env bash
# The whole test suite, from a fresh Debian 12 machine: installs what it needs, builds, and runs
# every test twice — once in the normal build, once built with AddressSanitizer + UBSan.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
jobs="$(nproc 2>/dev/null || echo 2)"

bash "$root/scripts/setup.sh"

# The builds are most of the suite's time. Line tables only (-g1) are enough for symbolized stack
# traces and perf; full debug info (-g) made the compiles ~35% slower. ASan + UBSan at -O2 compiled
# 2.6x slower than at -O1 (tests/io_gltf_test.cpp: 160 s against 62 s) and saved only a minute of
# test time (bench/RESULTS.md, session 36: the sanitizer build 29 -> 13 minutes); at -Og it
# compiles faster again (src/lod/generate.cpp: 53 s at -O1, 31 s at -Og; session 37: the sanitizer
# build 10.2 -> 6.8 minutes).
release_flags="-O2 -g1 -DNDEBUG"
sanitizer_flags="-Og -g1 -DNDEBUG"

echo "== build (RelWithDebInfo, -g1) =="
bash "$root/scripts/build.sh" "$root/build" \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$release_flags" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=$release_flags"
echo "== tests =="
(cd "$root/build" && ctest --output-on-failure -j"$jobs")

echo "== build (ASan + UBSan) =="
bash "$root/scripts/build.sh" "$root/build-asan" -DDUOLOD_SANITIZE=ON -DDUOLOD_BUILD_BENCH=OFF \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$sanitizer_flags" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=$sanitizer_flags"
echo "== tests under ASan + UBSan =="
# Mesa's llvmpipe and LLVM keep process-lifetime allocations; everything else must not leak.
# use_tls=0: GCC 12's LeakSanitizer misreads glibc 2.36's dynamic TLS of the dlopen'ed Mesa
# driver (a garbage range) and its tracer crashes ("Tracer caught signal 11") depending on the
# memory layout: `duolod render` with one output path and not another. Without the TLS scan, the
# loader's own allocations that only the TLS held read as leaks: tests/lsan.supp names them.
export LSAN_OPTIONS="suppressions=$root/tests/lsan.supp:print_suppressions=0:use_tls=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
(cd "$root/build-asan" && ctest --output-on-failure -j"$jobs")
