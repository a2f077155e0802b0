#!/usr/bin/env bash
# Builds the tests for aarch64-unknown-linux-gnu and runs them under qemu-aarch64 (user mode): the NEON kernel
# (src/resolve/simd/neon.rs) against the portable lanes, and the resolve's bit-identity across culling, tiles and
# threads, on an x86-64 machine. Installs what it needs on a fresh Debian machine (the rustup target, Debian's
# qemu-user and gcc-aarch64-linux-gnu); fails, never skips, when it cannot build or run them.
#
#   .ci/aarch64.sh            the CI subset of the tests (see TESTS below)
#   .ci/aarch64.sh --clippy   clippy for aarch64 first
#   .ci/aarch64.sh --all      every test target (slower; tests that spawn the aarch64 `gbuf` binary need
#                            binfmt_misc to run it, which a container may not have)
#
# The linker and the runner are set here through cargo's environment variables rather than in .cargo/config.toml:
# both paths are Debian's, and a [target.aarch64-unknown-linux-gnu] runner there would send a native aarch64
# developer's `cargo test --target aarch64-unknown-linux-gnu` through qemu too.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGET=aarch64-unknown-linux-gnu
SYSROOT=/usr/aarch64-linux-gnu
# The integration tests of the CI subset: the resolve's (bit-identical images across culling, tile size, thread
# count and sample order; finite output for every lane and on stiff inputs; packed targets lit as their unpacked
# G-buffer). With the library's unit tests (the NEON lanes against f64, the NEON kernel against the portable one)
# they run in about 3 minutes under qemu; the
# build takes most of the time (about 11 minutes from nothing on 2 shared cores).
TESTS=(resolve_props resolve_finite resolve_stiff resolve_packed)

need_apt=()
command -v qemu-aarch64 >/dev/null || need_apt+=(qemu-user)
command -v aarch64-linux-gnu-gcc >/dev/null || need_apt+=(gcc-aarch64-linux-gnu)
if [ ${#need_apt[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo=sudo
  echo "ci/aarch64: installing ${need_apt[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi
rustup target list --installed | grep -qx "$TARGET" || rustup target add "$TARGET"

export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L $SYSROOT"

# Warnings are errors in the aarch64 build: code behind cfg(target_arch) gates is only seen when built for it (an
# unused import there passes the x86 clippy). RUSTFLAGS for the target only: the host's build scripts and proc
# macros stay shared with the x86 build. `.ci/aarch64.sh --clippy` adds clippy for aarch64 (4–5 more minutes cold).
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUSTFLAGS="-D warnings"
if [ "${1:-}" = "--clippy" ]; then
  cargo clippy --target "$TARGET" --all-targets -- -D warnings
fi
if [ "${1:-}" = "--all" ]; then
  cargo test --target "$TARGET"
else
  args=(--lib)
  for t in "${TESTS[@]}"; do args+=(--test "$t"); done
  cargo test --target "$TARGET" "${args[@]}"
fi
