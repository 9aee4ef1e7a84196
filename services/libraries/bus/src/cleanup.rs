//! Removing what dead processes and finished runs leave behind.
//!
//! What iceoryx2 0.10 creates for a [`BusConfig`] (prefix `P`, root `R`), observed on Linux:
//!
//! - `R/nodes/P<node-id>.node_monitor{,_context,_owner_lock}` and `R/nodes/<node-id>/P*`
//!   (`.details`, `.service_tag`, `.port_tag`): one set per node;
//! - `R/services/P<hash>.service`: static service configuration;
//! - `R/P<id>.event`: the Unix datagram socket of each listener;
//! - `/dev/shm/P*`: shared memory (`.data` segments, `.connection`s, `.dynamic` service
//!   state, `.event_mgmt`) and one `P<hash>_node.0_10_0.global_mgmt` segment per prefix.
//!
//! When all processes end normally, everything but the empty `R/nodes`, `R/services` and the
//! `global_mgmt` segment is removed by iceoryx2 itself. A process that dies (SIGKILL, crash)
//! leaves its node's resources behind until [`cleanup_dead_nodes`] (or another node's
//! creation, which also cleans up dead nodes) removes them.

use std::io;
use std::path::Path;

use iceoryx2::node::{NodeState, NodeView};
use iceoryx2::prelude::*;

use crate::{BusConfig, BusError};

/// Where POSIX shared memory objects appear as files (Linux).
const SHM_DIR: &str = "/dev/shm";

/// Result of [`cleanup_dead_nodes`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CleanupReport {
    /// Nodes found alive.
    pub alive: usize,
    /// Dead nodes whose resources were removed, as `name (pid)`.
    pub cleaned: Vec<String>,
    /// Dead nodes that could not be cleaned, with the reason.
    pub failed: Vec<String>,
}

fn cleanup_error(config: &BusConfig, source: crate::Source) -> BusError {
    BusError::Cleanup {
        root: config.root_string(),
        prefix: config.prefix.clone(),
        source,
    }
}

fn describe<V: NodeView>(view: &V) -> String {
    match view.details() {
        Some(details) => format!("{} (pid {})", details.name(), details.process_id()),
        None => format!("node {:?}", view.id()),
    }
}

/// Removes the stale resources of every dead node (a process that ended without cleaning up)
/// of `config`'s bus. Safe while other processes of the run are alive; the launcher calls it
/// before starting a run and after stopping one.
pub fn cleanup_dead_nodes(config: &BusConfig) -> Result<CleanupReport, BusError> {
    let mut report = CleanupReport::default();
    if !config.root.join("nodes").is_dir() {
        return Ok(report);
    }
    let iox_config = config.to_iceoryx2()?;
    Node::<ipc::Service>::list(&iox_config, |state| {
        match state {
            NodeState::Alive(_) => report.alive += 1,
            NodeState::Dead(view) => {
                let what = describe(&view);
                match view.try_remove_stale_resources() {
                    Ok(()) => {
                        tracing::info!(node = %what, "removed stale resources of dead node");
                        report.cleaned.push(what);
                    }
                    Err(e) => {
                        tracing::warn!(node = %what, error = %e, "cannot clean up dead node");
                        report.failed.push(format!("{what}: {e}"));
                    }
                }
            }
            NodeState::Inaccessible(id) => {
                report
                    .failed
                    .push(format!("node {id:?}: inaccessible (permissions)"));
            }
            NodeState::Undefined(id) => {
                report.failed.push(format!("node {id:?}: undefined state"));
            }
        }
        CallbackProgression::Continue
    })
    .map_err(|e| cleanup_error(config, Box::new(e)))?;
    Ok(report)
}

/// Removes every file of `config`'s bus: files starting with the prefix below the root path
/// and in `/dev/shm`, then the directories left empty (the root itself included). Returns the
/// number of files removed.
///
/// For tests and for tearing down a finished run: it refuses while a node of the bus is alive,
/// and first cleans up dead nodes. Files of other prefixes under a shared root are kept.
pub fn remove_all(config: &BusConfig) -> Result<usize, BusError> {
    config.validate()?;
    let report = cleanup_dead_nodes(config)?;
    if report.alive > 0 {
        return Err(cleanup_error(
            config,
            format!("{} node(s) of the bus are still alive", report.alive).into(),
        ));
    }
    let io_error = |path: &Path, e: io::Error| {
        cleanup_error(config, format!("{}: {e}", path.display()).into())
    };
    let mut removed = 0;
    match std::fs::read_dir(SHM_DIR) {
        Ok(entries) => {
            for entry in entries.flatten() {
                if entry
                    .file_name()
                    .to_string_lossy()
                    .starts_with(&config.prefix)
                {
                    remove_file(&entry.path(), &mut removed)
                        .map_err(|e| io_error(&entry.path(), e))?;
                }
            }
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(io_error(Path::new(SHM_DIR), e)),
    }
    if config.root.is_dir() {
        remove_tree(&config.root, &config.prefix, &mut removed)
            .map_err(|e| io_error(&config.root, e))?;
    }
    Ok(removed)
}

fn remove_file(path: &Path, removed: &mut usize) -> io::Result<()> {
    match std::fs::remove_file(path) {
        Ok(()) => {
            *removed += 1;
            Ok(())
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Removes the files starting with `prefix` below `dir` and then `dir` itself if it is empty.
fn remove_tree(dir: &Path, prefix: &str, removed: &mut usize) -> io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let path = entry.path();
        if entry.file_type()?.is_dir() {
            remove_tree(&path, prefix, removed)?;
        } else if entry.file_name().to_string_lossy().starts_with(prefix) {
            remove_file(&path, removed)?;
        }
    }
    match std::fs::remove_dir(dir) {
        Ok(()) => Ok(()),
        // Not empty: files of another prefix share the root.
        Err(e) if e.kind() == io::ErrorKind::DirectoryNotEmpty => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}
