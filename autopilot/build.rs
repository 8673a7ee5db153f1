//! Puts the build's git hash into `FURROW_GIT_HASH` (eight hex digits, what
//! ArduPilot reports in AUTOPILOT_VERSION.flight_custom_version).
//!
//! `FURROW_GIT_HASH` in the build's environment wins (a packager building
//! from a tarball knows the commit); else `git rev-parse HEAD`; else, outside
//! a checkout or without `git`, eight zeros: a build never fails for want of
//! a repository.
//!
//! Only a hash taken from git makes the script watch the repository: a build
//! given its hash does not depend on HEAD, so a commit does not rebuild the
//! whole crate (with several worktrees of one repository, a commit in any of
//! them would otherwise rebuild all of them).

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8(out.stdout).ok()?;
    Some(text.trim().to_owned())
}

/// Rebuild when HEAD moves: HEAD itself and the branch it points at (loose
/// or packed). Only files that exist are named: cargo reruns a script
/// every build for a missing one.
fn watch_head() {
    let (Some(git_dir), Some(common_dir)) = (
        git(&["rev-parse", "--git-dir"]),
        git(&["rev-parse", "--git-common-dir"]),
    ) else {
        return;
    };
    let mut watched: Vec<PathBuf> = vec![
        Path::new(&git_dir).join("HEAD"),
        Path::new(&common_dir).join("packed-refs"),
    ];
    if let Some(branch) = git(&["rev-parse", "--symbolic-full-name", "HEAD"]).filter(|b| b.starts_with("refs/")) {
        watched.push(Path::new(&common_dir).join(branch));
    }
    for path in watched.iter().filter(|p| p.exists()) {
        println!("cargo:rerun-if-changed={}", path.display());
    }
}

/// Whether the C library here is glibc `major.minor` or newer
/// (`getconf GNU_LIBC_VERSION` says e.g. "glibc 2.36").
fn host_glibc_at_least(major: u32, minor: u32) -> bool {
    let Ok(out) = Command::new("getconf").arg("GNU_LIBC_VERSION").output() else {
        return false;
    };
    let text = String::from_utf8_lossy(&out.stdout);
    let version = text.trim().strip_prefix("glibc ").unwrap_or("");
    let mut parts = version.split('.').map(|p| p.parse::<u32>().ok());
    match (parts.next().flatten(), parts.next().flatten()) {
        (Some(a), Some(b)) => (a, b) >= (major, minor),
        _ => false,
    }
}

/// Links `furrow` with packed relative relocations (DT_RELR): the ~16,000
/// pointers in read-only data that a position-independent binary has the
/// loader fix up at start took 0.4 MB of `.rela.dyn`, read at every start
/// and resident from then on; packed they take 3 kB (RSS of `furrow sitl`
/// 0.5 MB less). The loader must know the format (glibc 2.36 and later), so
/// only a native build on such a glibc gets it: the binary runs where it
/// was built, and a cross build is linked as before.
fn pack_relative_relocs() {
    let var = |name: &str| std::env::var(name).unwrap_or_default();
    let native = var("TARGET") == var("HOST");
    let linux_gnu = var("CARGO_CFG_TARGET_OS") == "linux" && var("CARGO_CFG_TARGET_ENV") == "gnu";
    if native && linux_gnu && host_glibc_at_least(2, 36) {
        println!("cargo:rustc-link-arg-bins=-Wl,-z,pack-relative-relocs");
    }
}

fn main() {
    pack_relative_relocs();
    println!("cargo:rerun-if-env-changed=FURROW_GIT_HASH");
    let from_env = std::env::var("FURROW_GIT_HASH").ok();
    let from_git = || {
        watch_head();
        git(&["rev-parse", "HEAD"])
    };
    let hash = from_env
        .or_else(from_git)
        .filter(|h| h.len() >= 8 && h.bytes().all(|b| b.is_ascii_hexdigit()))
        .map_or_else(|| "00000000".to_owned(), |h| h[..8].to_ascii_lowercase());
    println!("cargo:rustc-env=FURROW_GIT_HASH={hash}");
}
