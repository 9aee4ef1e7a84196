//! Roles: the launcher and every pipeline process are one executable (`testbed`), started under
//! the name of the role it plays, busybox style: its `main` reads the name it was started under
//! ([`invoked_as`]) and runs that role.
//!
//! A role is started by executing a symbolic link named after it ([`RoleLinks`]): the kernel
//! names a process by the file name it executes, not by the file a link points to, so the
//! process is named by its role in `ps` and `/proc/PID/comm` from its `exec` on (the watchdog,
//! tests and users find the processes by that name), and its `argv[0]` says the role.

use std::io;
use std::os::unix::fs::{DirBuilderExt as _, MetadataExt as _};
use std::path::{Path, PathBuf};

use testbed_bus::BusConfig;

/// The launcher's role: the name `testbed` is started under to be the launcher.
pub const LAUNCHER: &str = "testbed-launch";

/// The name this program was started under (the last component of `argv[0]`): which role it
/// plays.
pub fn invoked_as() -> Option<String> {
    let arg0 = std::env::args_os().next()?;
    Path::new(&arg0).file_name()?.to_str().map(str::to_owned)
}

/// Where the role links of a run on `bus` are: a directory in the bus root named after the
/// prefix, so that runs sharing a root keep theirs apart, and one removed with a private root.
pub fn links_dir(bus: &BusConfig) -> PathBuf {
    let prefix = bus.prefix.trim_end_matches('_');
    bus.root.join(format!("roles-{prefix}"))
}

/// The roles a launcher starts: a profile's non-absolute `command` names one.
#[derive(Debug, Clone)]
pub struct Roles {
    /// The names of the roles of [`Roles::exe`].
    pub names: Vec<String>,
    /// The executable the roles are of (the launcher's own).
    pub exe: PathBuf,
    /// Where the run's links to it are made ([`links_dir`]).
    pub dir: PathBuf,
}

impl Roles {
    /// Whether `command` names a role.
    pub fn contains(&self, command: &str) -> bool {
        self.names.iter().any(|name| name == command)
    }
}

/// A directory of symbolic links `<dir>/<role>` to one executable; removed when dropped.
#[derive(Debug)]
pub struct RoleLinks {
    dir: PathBuf,
}

impl RoleLinks {
    /// Makes `dir` (mode 0700, and its missing parents so, as the bus root may not exist yet
    /// when the launcher starts) with a link `<dir>/<name>` → `exe` for
    /// each of `names`, replacing links of those names already there. An existing `dir` is
    /// used only if it is a directory of this user's that nobody else may write to: whoever
    /// could put a link in it would choose what the run executes.
    pub fn create<'a>(
        dir: &Path,
        exe: &Path,
        names: impl IntoIterator<Item = &'a str>,
    ) -> io::Result<Self> {
        let context = |what: &str, path: &Path, e: io::Error| {
            io::Error::new(e.kind(), format!("{what} {}: {e}", path.display()))
        };
        if let Some(parent) = dir.parent() {
            std::fs::DirBuilder::new()
                .recursive(true)
                .mode(0o700)
                .create(parent)
                .map_err(|e| context("creating", parent, e))?;
        }
        match std::fs::DirBuilder::new().mode(0o700).create(dir) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                let meta =
                    std::fs::symlink_metadata(dir).map_err(|e| context("reading", dir, e))?;
                // SAFETY: geteuid has no preconditions.
                let own = meta.uid() == unsafe { libc::geteuid() };
                if !meta.is_dir() || !own || meta.mode() & 0o022 != 0 {
                    return Err(io::Error::new(
                        io::ErrorKind::PermissionDenied,
                        format!(
                            "{} exists but is not a directory of this user's closed to others",
                            dir.display()
                        ),
                    ));
                }
            }
            Err(e) => return Err(context("creating", dir, e)),
        }
        let links = Self {
            dir: dir.to_path_buf(),
        };
        for name in names {
            let link = links.path(name);
            match std::fs::remove_file(&link) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(context("replacing", &link, e)),
            }
            std::os::unix::fs::symlink(exe, &link).map_err(|e| context("creating", &link, e))?;
        }
        Ok(links)
    }

    /// The link that starts `role`.
    pub fn path(&self, role: &str) -> PathBuf {
        self.dir.join(role)
    }
}

impl Drop for RoleLinks {
    fn drop(&mut self) {
        match std::fs::remove_dir_all(&self.dir) {
            Ok(()) => {}
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => tracing::warn!("removing the role links {}: {e}", self.dir.display()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_link_runs_its_target_under_the_role_name() {
        let base = std::env::temp_dir().join(format!("roles-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        // The parent is made too.
        let dir = base.join("links");
        let links = RoleLinks::create(&dir, Path::new("/bin/sh"), ["role-a"]).unwrap();
        // Made again over the existing directory and link (a second creator of the run's links).
        let again = RoleLinks::create(&dir, Path::new("/bin/sh"), ["role-a", "role-b"]).unwrap();
        let out = std::process::Command::new(again.path("role-a"))
            .args(["-c", "cat /proc/$$/comm"])
            .output()
            .unwrap();
        assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "role-a");
        std::mem::forget(again);
        drop(links);
        assert!(!dir.exists(), "the links were left behind");

        // A directory others may write to is refused.
        std::fs::create_dir(&dir).unwrap();
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
        let refused = RoleLinks::create(&dir, Path::new("/bin/sh"), ["role-a"]).unwrap_err();
        assert_eq!(refused.kind(), io::ErrorKind::PermissionDenied, "{refused}");
        std::fs::remove_dir_all(&base).unwrap();
    }
}
