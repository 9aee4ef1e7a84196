//! Where `testbed run --profile NAME` finds the profile NAME.

use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// Where profiles are looked up by name: `$TESTBED_PROFILES`, then `launch/profiles` of the
/// source tree the executable was built in, then `launch/profiles` in the working directory.
pub fn profile_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("TESTBED_PROFILES")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    if let Some(root) = std::env::current_exe()
        .ok()
        .and_then(|e| e.ancestors().nth(3).map(Path::to_path_buf))
    {
        dirs.push(root.join("launch/profiles")); // <root>/target/<profile>/testbed
    }
    dirs.push(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../launch/profiles"));
    dirs.push(PathBuf::from("launch/profiles"));
    dirs
}

/// The profile names (`*.toml` stems) in `dir`, sorted.
pub fn profile_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    names.sort();
    names
}

/// A profile name (see [`profile_dirs`]) or a path.
pub fn find_profile(name: &str) -> Result<PathBuf> {
    let as_path = PathBuf::from(name);
    if as_path.extension().is_some_and(|e| e == "toml") || as_path.components().count() > 1 {
        return Ok(as_path);
    }
    let file = format!("{name}.toml");
    let dirs = profile_dirs();
    if let Some(found) = dirs.iter().map(|d| d.join(&file)).find(|p| p.is_file()) {
        return Ok(found);
    }
    match dirs.iter().find(|d| d.is_dir()) {
        Some(dir) => bail!(
            "no profile `{name}`; the profiles are {} (in {}), or give the path of a .toml file",
            profile_names(dir).join(", "),
            dir.display()
        ),
        None => bail!(
            "no profile `{name}`: no launch/profiles directory found (set TESTBED_PROFILES or give the path of a .toml file)"
        ),
    }
}
