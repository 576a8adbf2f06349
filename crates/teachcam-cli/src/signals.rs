//! SIGINT (Ctrl-C) and SIGTERM. Every command ends on either with one line on stderr and the
//! shell's status for it, 128 + the signal: 130 for SIGINT, 143 for SIGTERM. The temporaries
//! of unfinished outputs are removed first, so no output is left half written (each is renamed
//! whole or not at all; ARCHITECTURE.md, "Outputs and exit codes"). `record`, `live` and
//! `studio` instead finish the frame set in hand (a valid recording, a summary) and then end:
//! 0 after SIGINT (their usual stop), 143 after SIGTERM.

use std::process::ExitCode;
use std::sync::atomic::{AtomicI32, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// The signal that asked a capture command to stop (0: none yet).
static STOP: AtomicI32 = AtomicI32::new(0);

/// The signal's name as the line says it.
fn name(signal: i32) -> &'static str {
    if signal == SIGTERM {
        "SIGTERM"
    } else {
        "SIGINT"
    }
}

/// The shell's exit status for a process ended by `signal`: 128 + its number.
fn status(signal: i32) -> u8 {
    u8::try_from(128 + signal).unwrap_or(u8::MAX)
}

/// Handles SIGINT and SIGTERM on a thread of their own: a capture command (`capture`) records
/// the request ([`stop_requested`]); any other removes its live temporaries, says so in one
/// line and exits with [`status`]. Without the handler (the signals cannot be registered) an
/// interrupt ends the process by the default action, which leaves temporaries that the next
/// run in that folder removes.
#[expect(clippy::print_stderr, reason = "an interrupted command says so")]
pub fn handle(capture: bool) {
    let Ok(mut signals) = Signals::new([SIGINT, SIGTERM]) else {
        return;
    };
    std::thread::spawn(move || {
        for signal in signals.forever() {
            if capture {
                // The first request is the one the command answers.
                let _ = STOP.compare_exchange(0, signal, Ordering::SeqCst, Ordering::SeqCst);
                continue;
            }
            teachcam::io::output::remove_live_temporaries();
            eprintln!(
                "interrupted by {}: stopped; no output written in part",
                name(signal)
            );
            std::process::exit(i32::from(status(signal)));
        }
    });
}

/// True once SIGINT or SIGTERM asked a capture command to stop.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst) != 0
}

/// How a capture command that ended cleanly exits: success, or 143 after SIGTERM (with its
/// line), since a service manager's stop is not the user's.
#[expect(clippy::print_stderr, reason = "a stopped command says why it ends")]
pub fn capture_exit() -> ExitCode {
    match STOP.load(Ordering::SeqCst) {
        SIGTERM => {
            eprintln!("stopped by SIGTERM after the frame set in hand; what was written is whole");
            ExitCode::from(status(SIGTERM))
        }
        _ => ExitCode::SUCCESS,
    }
}
