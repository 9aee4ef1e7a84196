//! `sys::any_exited`, the launcher's one-call check for an ended child, in a test binary of its
//! own: it asks about every child of the process, so no other test may start children beside it.

use std::time::{Duration, Instant};
use testbed_launch::sys;

#[test]
fn any_exited_sees_an_ended_child_without_reaping_it() {
    assert!(!sys::any_exited().unwrap(), "no child yet");
    let mut child = std::process::Command::new("sleep")
        .arg("0.3")
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    assert!(!sys::any_exited().unwrap(), "the child is still running");
    let deadline = Instant::now() + Duration::from_secs(10);
    while !sys::any_exited().unwrap() {
        assert!(Instant::now() < deadline, "the child's end was never seen");
        std::thread::sleep(Duration::from_millis(20));
    }
    // Not reaped: the per-process query still sees it, and asking again says the same.
    assert!(sys::has_exited(pid).unwrap());
    assert!(sys::any_exited().unwrap());
    assert!(child.wait().unwrap().success());
    assert!(
        !sys::any_exited().unwrap(),
        "reaped: no child has ended any more"
    );
}
