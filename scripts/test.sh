#!/usr/bin/env bash
# The test command (README): installs what the tests need, then runs every test in release mode.
set -euo pipefail
cd "$(dirname "$0")/.."

# The wgpu backend's tests (tests/parity.rs) need a Vulkan driver; without a GPU that is Mesa's
# software rasteriser lavapipe. Install it when missing and we can (root + apt-get). Without an
# adapter the GPU tests print that they were skipped and why — except under CI=true, where they fail.
has_vulkan() {
    ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1' &&
        ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1
}
if ! has_vulkan; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        echo "test.sh: no Vulkan driver found; installing Mesa's software Vulkan (mesa-vulkan-drivers libvulkan1)"
        apt-get update -qq && apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null ||
            echo "test.sh: warning: installing mesa-vulkan-drivers failed; GPU tests will be skipped (fail under CI=true)"
    else
        echo "test.sh: no Vulkan driver and no way to install one (needs root and apt-get):" \
             "GPU tests will be skipped (fail under CI=true). Install with: apt-get install mesa-vulkan-drivers libvulkan1"
    fi
fi

# The GL backend (`WGPU_BACKEND=gl`, what wgpu uses without Vulkan) runs headless through EGL on
# Mesa's llvmpipe: tests/parity.rs `parity_on_the_gl_backend` needs libegl1 + libgl1-mesa-dri.
has_gl() {
    ldconfig -p 2>/dev/null | grep -q 'libEGL\.so\.1' &&
        ls /usr/lib/*/dri/swrast_dri.so /usr/lib/dri/swrast_dri.so >/dev/null 2>&1
}
if ! has_gl; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        echo "test.sh: no EGL/GL driver found; installing Mesa's (libegl1 libgl1-mesa-dri)"
        apt-get update -qq && apt-get install -y -qq libegl1 libgl1-mesa-dri >/dev/null ||
            echo "test.sh: warning: installing libegl1 libgl1-mesa-dri failed; the GL parity test will be skipped (fails under CI=true)"
    else
        echo "test.sh: no EGL/GL driver and no way to install one (needs root and apt-get): the GL parity test" \
             "will be skipped (fails under CI=true). Install with: apt-get install libegl1 libgl1-mesa-dri"
    fi
fi

# `wedge view`'s window test (tests/view.rs) runs the viewer under Xvfb (Debian `xvfb`: xvfb-run).
# Without it the test prints that it was skipped and why — except under CI=true, where it fails.
if ! command -v xvfb-run >/dev/null 2>&1; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        echo "test.sh: xvfb-run not found; installing Xvfb (xvfb)"
        apt-get update -qq && apt-get install -y -qq xvfb >/dev/null ||
            echo "test.sh: warning: installing xvfb failed; the window test will be skipped (fails under CI=true)"
    else
        echo "test.sh: no xvfb-run and no way to install it (needs root and apt-get): the window test" \
             "will be skipped (fails under CI=true). Install with: apt-get install xvfb"
    fi
fi

# `wedge farm slurm` on a real one-node Slurm (tests/farm_slurm.rs: munged, slurmctld and slurmd on
# localhost from a generated slurm.conf in a temp dir, ~10 s): Debian's slurm-wlm and munge. Without
# them the test prints that it was skipped and why — except under CI=true, where it fails.
if ! command -v slurmctld >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1; then
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        echo "test.sh: slurmctld/munged not found; installing Slurm (slurm-wlm munge)"
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null ||
            echo "test.sh: warning: installing slurm-wlm munge failed; the Slurm test will be skipped (fails under CI=true)"
    else
        echo "test.sh: no Slurm and no way to install it (needs root and apt-get): the Slurm test" \
             "will be skipped (fails under CI=true). Install with: apt-get install slurm-wlm munge"
    fi
fi

# Mesa's software drivers (lavapipe for Vulkan, llvmpipe for GL) compile every shader through LLVM's
# optimisation passes; on a machine with an empty shader cache (every CI run) that compile was most of
# the GPU tests' time. `nopt` skips the passes: the outputs are the same bit for bit (checked on the
# EXRs of three pipelines), shaders run about 2x slower, and the tests' small images do not notice:
# tests/parity.rs + tests/combination_matrix.rs with an empty cache took about half as long
# (docs/DESIGN-NOTES.md, "Cold compiles in CI"). Real GPUs ignore the variable; set it to override.
export GALLIVM_PERF="${GALLIVM_PERF:-nopt}"

# Formatting (rustfmt.toml: 120 columns): seconds, so first; a change that is not `cargo fmt`-clean
# fails here with the diff. Then clippy with warnings as errors (issue 36 §5), before the long test
# build so a lint fails fast; it checks the dependencies once more in check mode (a few minutes).
cargo fmt --all --check
cargo fmt --manifest-path examples/fog/Cargo.toml --check
cargo fmt --manifest-path checks/k8s_schema/Cargo.toml --check
if cargo clippy --version >/dev/null 2>&1; then
    cargo clippy --release --workspace --all-targets -- -D warnings
else
    echo "test.sh: cargo clippy is not installed (rustup component add clippy): lints skipped"
fi

cargo test --release --workspace --all-targets "$@"

# `wedge farm k8s`'s manifests against the Kubernetes schemas (checks/k8s_schema: outside the workspace,
# so that jsonschema's serde_json features do not reach the other crates' tests), with the wedge just built.
WEDGE_BIN="${CARGO_TARGET_DIR:-$PWD/target}/release/wedge" CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}" \
    cargo test --release --manifest-path checks/k8s_schema/Cargo.toml "$@"

# The user-crate example (examples/fog: outside the workspace; its own node, kernel + WGSL, and the
# binary `wedge-fog` = wedge's whole CLI with Fog added, run through render/reference/bench/parity).
# Shares the target directory so wgpu is not rebuilt.
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$PWD/target}" \
    cargo test --release --all-targets --manifest-path examples/fog/Cargo.toml "$@"
