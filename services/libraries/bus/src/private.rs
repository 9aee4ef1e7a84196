//! Private per-run buses, and collecting what runs that died left behind.
//!
//! A run's bus used to live in `/tmp/tb<pid>/` with prefix `tb<pid>_`: predictable, so another
//! local user who created that directory (or a `/dev/shm/tb<pid>_…` file) first made the run
//! fail (a local denial of service), and a run killed with SIGKILL left its files for ever.
//!
//! [`PrivateRun::create`] makes a directory `<base>/<tag><pid>_<random>` with `mkdir` mode
//! 0700 (the name is unpredictable, and `mkdir` fails rather than reuse an existing one, so
//! the directory is the caller's own), and uses its name plus `_` as the iceoryx2 prefix, so
//! the shared-memory files in `/dev/shm` are unpredictable too. [`collect_dead_runs`] removes
//! the buses of earlier runs whose owning process is gone: it finds them by that name pattern
//! (and the older `<tag><pid>` pattern) below `base` and in `/dev/shm`.

use std::collections::BTreeSet;
use std::io::{self, Read as _};
use std::os::unix::fs::{DirBuilderExt as _, MetadataExt as _};
use std::path::{Path, PathBuf};

use crate::{BusConfig, remove_all};

/// Where POSIX shared memory objects appear as files (Linux).
const SHM_DIR: &str = "/dev/shm";
/// Random characters in a private run's name (6 of 62: about 5.7e10 names per pid).
const RANDOM_LEN: usize = 6;
const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";

/// A run's private bus: its [`BusConfig`] (prefix = directory name + `_`, root = directory).
#[derive(Debug, Clone)]
pub struct PrivateRun {
    /// The bus (default delivery and limits: the launcher sets the delivery from the mode).
    pub bus: BusConfig,
}

impl PrivateRun {
    /// Creates `<base>/<tag><pid>_<random>/` (mode 0700, failing rather than reusing an
    /// existing path). `tag` is a few letters (`tb`); `base` an absolute, short directory
    /// (`/tmp`): the root must stay within [`crate::MAX_ROOT_LEN`].
    pub fn create(base: &Path, tag: &str) -> io::Result<Self> {
        let pid = std::process::id();
        let mut last = None;
        // A collision (EEXIST) is unlikely; someone squatting names is what the retries are for.
        for _ in 0..16 {
            let name = format!("{tag}{pid}_{}", random_name()?);
            let root = base.join(&name);
            match std::fs::DirBuilder::new().mode(0o700).create(&root) {
                Ok(()) => {
                    let run = Self {
                        bus: BusConfig::new(format!("{name}_"), root),
                    };
                    if let Err(e) = run
                        .bus
                        .validate()
                        .map_err(io::Error::other)
                        .and_then(|()| run.make_global_segment_private())
                    {
                        let _ = run.remove();
                        return Err(e);
                    }
                    return Ok(run);
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
                Err(e) => {
                    return Err(io::Error::new(
                        e.kind(),
                        format!("creating the bus root {}: {e}", root.display()),
                    ));
                }
            }
        }
        Err(last.unwrap_or_else(|| io::Error::other("no free bus root name")))
    }

    /// iceoryx2 0.10 creates one shared-memory segment per prefix, `<prefix>…global_mgmt`
    /// (the node-id counter), readable and writable by everyone (0666, its `enable_global_access`
    /// builder option; no configuration changes it, and `fchmod` ignores the umask). Creating it
    /// here, before any process of the run exists, and taking the group's and others' access
    /// away leaves every file of the run private to the user (the processes only need the
    /// owner's access to open it).
    fn make_global_segment_private(&self) -> io::Result<()> {
        use iceoryx2::prelude::*;
        use std::os::unix::fs::PermissionsExt as _;
        let config = self.bus.to_iceoryx2().map_err(io::Error::other)?;
        let node = NodeBuilder::new()
            .config(&config)
            .create::<ipc::Service>()
            .map_err(|e| io::Error::other(format!("creating the bus's first node: {e:?}")))?;
        drop(node);
        let mut found = false;
        for entry in std::fs::read_dir(SHM_DIR)?.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if !name.starts_with(&self.bus.prefix) {
                continue;
            }
            found |= name.ends_with("global_mgmt");
            let mode = entry.metadata()?.permissions().mode();
            if mode & 0o077 != 0 {
                std::fs::set_permissions(
                    entry.path(),
                    std::fs::Permissions::from_mode(mode & 0o700),
                )?;
            }
        }
        if !found {
            return Err(io::Error::other(format!(
                "no iceoryx2 global_mgmt segment with prefix {} in {SHM_DIR}",
                self.bus.prefix
            )));
        }
        Ok(())
    }

    /// Removes every file of the bus and its root directory (call when no process of the run
    /// is left; refused while a node of the bus is alive).
    pub fn remove(&self) -> Result<usize, crate::BusError> {
        let removed = remove_all(&self.bus)?;
        // remove_all keeps a root holding files of other prefixes; this root is the run's own.
        match std::fs::remove_dir_all(&self.bus.root) {
            Ok(()) => Ok(removed),
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(removed),
            Err(e) => Err(crate::BusError::Cleanup {
                root: self.bus.root_string(),
                prefix: self.bus.prefix.clone(),
                source: format!("{}: {e}", self.bus.root.display()).into(),
            }),
        }
    }
}

fn random_name() -> io::Result<String> {
    let mut bytes = [0u8; RANDOM_LEN];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes
        .iter()
        .map(|b| char::from(ALPHABET[usize::from(*b) % ALPHABET.len()]))
        .collect())
}

/// What [`collect_dead_runs`] did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CollectReport {
    /// Prefixes of dead runs whose files were removed, with the number of files.
    pub removed: Vec<(String, usize)>,
    /// Prefixes that could not be removed, with the reason.
    pub failed: Vec<String>,
}

/// The owning pid of a run name `<tag><pid>` or `<tag><pid>_<random>` (a directory name, or
/// the start of a shared-memory file name up to the prefix's `_`).
fn run_pid(name: &str, tag: &str) -> Option<u32> {
    let rest = name.strip_prefix(tag)?;
    let (pid, random) = match rest.split_once('_') {
        Some((pid, random)) => (pid, Some(random)),
        None => (rest, None),
    };
    if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if random
        .is_some_and(|r| r.len() != RANDOM_LEN || !r.bytes().all(|b| b.is_ascii_alphanumeric()))
    {
        return None;
    }
    pid.parse().ok()
}

/// Whether process `pid` exists. A pid reused since by another program keeps the dead run's
/// files until that program ends too: never removing a live run's bus matters more.
fn alive(pid: u32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
}

/// Removes the buses of runs made by [`PrivateRun::create`] (`<base>/<tag><pid>_<random>`,
/// prefix `<tag><pid>_<random>_`) and by older versions (`<base>/<tag><pid>`, prefix
/// `<tag><pid>_`) whose process `<pid>` is gone, along with their files in `/dev/shm`. Only
/// directories and files owned by this user are touched, and a bus with a live node is kept
/// (see [`remove_all`]).
pub fn collect_dead_runs(base: &Path, tag: &str) -> CollectReport {
    let uid = own_uid();
    let mut report = CollectReport::default();
    let mut candidates: BTreeSet<(String, PathBuf)> = BTreeSet::new();
    let owned = |meta: &std::fs::Metadata| uid.is_none_or(|u| meta.uid() == u);
    if let Ok(entries) = std::fs::read_dir(base) {
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let is_own_dir = entry
                .path()
                .symlink_metadata()
                .is_ok_and(|m| m.is_dir() && owned(&m));
            if is_own_dir && run_pid(&name, tag).is_some() {
                candidates.insert((format!("{name}_"), entry.path()));
            }
        }
    }
    if let Ok(entries) = std::fs::read_dir(SHM_DIR) {
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let Some(prefix) = shm_prefix(&name, tag) else {
                continue;
            };
            if entry.metadata().is_ok_and(|m| owned(&m))
                && !candidates.iter().any(|(p, _)| *p == prefix)
            {
                let root = base.join(prefix.trim_end_matches('_'));
                candidates.insert((prefix, root));
            }
        }
    }
    for (prefix, root) in candidates {
        let Some(pid) = run_pid(prefix.trim_end_matches('_'), tag) else {
            continue;
        };
        if pid == std::process::id() || alive(pid) {
            continue;
        }
        let bus = BusConfig::new(prefix.clone(), root.clone());
        if bus.validate().is_err() {
            continue;
        }
        match remove_all(&bus) {
            Ok(n) => {
                // Only a private root (with the random part) is the run's own to remove whole.
                if prefix.matches('_').count() == 2 {
                    let _ = std::fs::remove_dir_all(&root);
                }
                report.removed.push((prefix, n));
            }
            Err(e) => report.failed.push(format!("{prefix}: {e}")),
        }
    }
    report
}

/// The run prefix a `/dev/shm` file name starts with, if it is one of ours: `<tag><pid>_` or
/// `<tag><pid>_<random>_`.
fn shm_prefix(name: &str, tag: &str) -> Option<String> {
    let mut parts = name.splitn(3, '_');
    let first = parts.next()?;
    run_pid(first, tag)?;
    let second = parts.next()?;
    let with_random = format!("{first}_{second}");
    if second.len() == RANDOM_LEN && run_pid(&with_random, tag).is_some() && parts.next().is_some()
    {
        Some(format!("{with_random}_"))
    } else {
        Some(format!("{first}_"))
    }
}

/// This process's effective uid: the owner of its `/proc/self` (no libc call needed).
fn own_uid() -> Option<u32> {
    std::fs::metadata("/proc/self").ok().map(|m| m.uid())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_parsed() {
        assert_eq!(run_pid("tb123_Ab9xYz", "tb"), Some(123));
        assert_eq!(run_pid("tb123", "tb"), Some(123));
        assert_eq!(run_pid("tb123_toolong7", "tb"), None);
        assert_eq!(run_pid("tbx_Ab9xYz", "tb"), None);
        assert_eq!(run_pid("other", "tb"), None);
        assert_eq!(
            shm_prefix("tb123_Ab9xYz_abc.data", "tb").as_deref(),
            Some("tb123_Ab9xYz_")
        );
        assert_eq!(
            shm_prefix("tb123_iox2_abc.data", "tb").as_deref(),
            Some("tb123_")
        );
        assert_eq!(shm_prefix("ix-1_x", "tb"), None);
    }

    #[test]
    fn private_roots_are_private_and_unpredictable() {
        let base = Path::new("/tmp");
        let a = PrivateRun::create(base, "tq").expect("created");
        let b = PrivateRun::create(base, "tq").expect("created");
        assert_ne!(a.bus.root, b.bus.root);
        let meta = std::fs::metadata(&a.bus.root).expect("exists");
        use std::os::unix::fs::PermissionsExt as _;
        assert_eq!(meta.permissions().mode() & 0o777, 0o700);
        assert_eq!(Some(meta.uid()), own_uid());
        assert!(
            a.bus
                .prefix
                .starts_with(&format!("tq{}_", std::process::id()))
        );
        // The global management segment exists and is the owner's only.
        let shm: Vec<_> = std::fs::read_dir(SHM_DIR)
            .expect("shm")
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(&a.bus.prefix))
            .map(|e| {
                (
                    e.file_name(),
                    e.metadata().expect("meta").permissions().mode(),
                )
            })
            .collect();
        assert!(!shm.is_empty(), "no segment");
        assert!(shm.iter().all(|(_, mode)| mode & 0o077 == 0), "{shm:?}");
        a.remove().expect("removed");
        b.remove().expect("removed");
        assert!(!a.bus.root.exists());
    }

    #[test]
    fn dead_runs_are_collected_and_live_ones_kept() {
        // A pid no process has (pid_max is at most 4194304).
        let dead_pid = (1_000_000..4_194_304u32)
            .rev()
            .find(|p| !alive(*p))
            .expect("a free pid");
        let name = format!("tz{dead_pid}_{}", random_name().expect("random"));
        let dead = Path::new("/tmp").join(&name);
        std::fs::create_dir(&dead).expect("created");
        std::fs::create_dir(dead.join("nodes")).expect("created");
        let prefix = format!("{name}_");
        let shm = Path::new(SHM_DIR).join(format!("{prefix}leftover.data"));
        std::fs::write(&shm, b"x").expect("written");
        let live = PrivateRun::create(Path::new("/tmp"), "tz").expect("created");
        let live_shm = Path::new(SHM_DIR).join(format!("{}leftover.data", live.bus.prefix));
        std::fs::write(&live_shm, b"x").expect("written");

        let report = collect_dead_runs(Path::new("/tmp"), "tz");
        assert!(
            report.removed.iter().any(|(p, n)| *p == prefix && *n >= 1),
            "{report:?}"
        );
        assert!(!shm.exists() && !dead.exists(), "{report:?}");
        // This process's own run is alive: kept.
        assert!(live.bus.root.exists() && live_shm.exists(), "{report:?}");
        live.remove().expect("removed");
        assert!(!live_shm.exists());
    }
}
