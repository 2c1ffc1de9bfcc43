//! Ctrl-C while `tprf render` writes its folder: the files written so far are dropped
//! with their staging folder and the old output stays as it was, instead of a temporary
//! folder left beside it. Before writing nothing is on disk yet, so Ctrl-C ends the
//! process at once as usual (but for `--until-stopped`, whose passes end at the first
//! Ctrl-C: [`take`]); a second Ctrl-C while writing does too.

use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

static INTERRUPTED: AtomicBool = AtomicBool::new(false);
static CATCH: Once = Once::new();

/// From now on, Ctrl-C (SIGINT) only marks the command as interrupted, for [`check`]; a
/// second one ends the process.
pub(super) fn catch() {
    #[cfg(unix)]
    CATCH.call_once(|| {
        // SAFETY: the action only touches an atomic and calls `_exit`, both
        // async-signal-safe.
        let registered = unsafe {
            signal_hook_registry::register(libc::SIGINT, || {
                if INTERRUPTED.swap(true, Ordering::SeqCst) {
                    libc::_exit(130);
                }
            })
        };
        // Without the handler Ctrl-C keeps its default action: the staging folder may
        // then be left behind, nothing worse.
        let _ = registered;
    });
    #[cfg(not(unix))]
    CATCH.call_once(|| {});
}

/// An error once Ctrl-C was pressed after [`catch`].
pub(super) fn check() -> anyhow::Result<()> {
    if INTERRUPTED.load(Ordering::SeqCst) {
        anyhow::bail!("interrupted (Ctrl-C) while writing: nothing was written");
    }
    Ok(())
}

/// Whether Ctrl-C was pressed since [`catch`] (or the last `take`), the mark cleared: a
/// render until Ctrl-C ends its passes on it, and a next Ctrl-C is seen while writing.
pub(super) fn take() -> bool {
    INTERRUPTED.swap(false, Ordering::SeqCst)
}
