//! Stored programs: transfer, flash, erase, runs with loops, branches,
//! delays, port conditions, sync characters (isel manual 2.2.13, 2.2.17,
//! 2.2.23, chapter 3, 4.2.11-4.2.14; decisions 9-11).

use std::time::Duration;

use super::{Conv, default_config};
use crate::sim::SimDevice;

const MINUTE: Duration = Duration::from_secs(60);

fn store(c: &mut Conv, lines: &[&str]) {
    c.expect("@0i", "0");
    for line in lines {
        c.expect(line, "0");
    }
}

#[test]
fn a_program_with_a_loop_and_a_branch_ends_where_predicted() {
    let mut c = Conv::referenced();
    store(
        &mut c,
        &[
            "0100,2000,0,100,0,100,0,100",    // 0: x += 100
            "3 4,-1",                         // 1: 0 four more times: x = 500
            "3 0,2",                          // 2: jump over 3
            "0100000,2000,0,100,0,100,0,100", // 3: skipped
            "00,100,50,2000,0,100,0,100",     // 4: y += 50
            "3 2,-3",                         // 5: 2..=4 twice more: y = 150
            "m0,2000,0,2000,10,2000,0,100",   // 6: x 0, y 0, z 10
            "9",
        ],
    );
    c.expect("@0i", "G");
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position(), [0, 0, 10]);
    // Take the final move out by running without it: x 500, y 150.
    c.expect_after("@0k", "0", Duration::from_secs(3));
    store(
        &mut c,
        &[
            "0100,2000,0,100,0,100,0,100",
            "3 4,-1",
            "3 0,2",
            "0100000,2000,0,100,0,100,0,100",
            "00,100,50,2000,0,100,0,100",
            "3 2,-3",
            "9",
        ],
    );
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position(), [500, 150, 10]);
}

#[test]
fn a_stored_program_answers_g_to_at_i_until_erased() {
    let mut c = Conv::new();
    c.expect("@0i", "4");
    c.expect("@07", "0");
    c.expect("@0S", "G");
    store(&mut c, &["5 1"]);
    // A bad line ends the transfer: the controller is back in DNC mode and
    // the partial program is invalid.
    c.expect("010,900", "7");
    assert_eq!(c.ask("@0b1"), "003");
    c.expect("@0i", "G");
    c.expect("@0S", "G");
    // Erasing takes about 2 s; bytes meanwhile are lost.
    c.send("@0k");
    c.wait(Duration::from_millis(500));
    c.send("@0P");
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    assert!(took >= Duration::from_millis(1400), "{took:?}");
    c.silent_for(Duration::from_millis(100));
    c.expect("@0i", "0");
    // DNC-only commands cannot be stored; `@` lines neither.
    c.expect("@0P", "8");
    c.expect("@0i", "G");
}

#[test]
fn program_memory_holds_the_configured_number_of_commands() {
    let mut config = default_config();
    config.program_capacity = 3;
    let mut c = Conv::with(config);
    c.expect("@07", "0");
    store(&mut c, &["5 1", "5 1", "5 1"]);
    c.expect("5 1", "6");
    let mut c = Conv::with({
        let mut config = default_config();
        config.program_capacity = 3;
        config
    });
    c.expect("@07", "0");
    store(&mut c, &["5 1", "5 1", "5 1", "9"]);
}

#[test]
fn the_operator_can_shrink_the_program_memory() {
    let mut c = Conv::new();
    assert!(c.sim.set_program_memory(2001).is_err());
    c.sim.set_program_memory(2).unwrap();
    c.expect("@07", "0");
    store(&mut c, &["5 1", "5 1"]);
    c.expect("5 2", "6");
}

#[test]
fn delays_sync_characters_and_the_wait_for_one() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    store(
        &mut c,
        &[
            "133",    // 0: send `!`
            "5 5",    // 1: half a second
            "2 65,2", // 2: wait; `A` jumps to 4
            "166",    // 3: send `B`
            "167",    // 4: send `C`
            "9",
        ],
    );
    c.send("@0S");
    let (sync, at) = c.next_reply(MINUTE).expect("sync");
    assert_eq!((sync.as_str(), at), ("!", Duration::ZERO));
    c.silent_for(Duration::from_millis(600));
    // The program waits for a character; a command is no command now.
    c.send_bytes(b"A");
    let (c1, _) = c.next_reply(MINUTE).expect("C");
    assert_eq!(c1, "C");
    assert_eq!(c.next_reply(MINUTE).expect("end").0, "0");
    // Any other character goes on with the next command.
    c.send("@0S");
    assert_eq!(c.next_reply(MINUTE).expect("!").0, "!");
    c.wait(Duration::from_millis(600));
    c.send_bytes(b"x");
    c.wait(Duration::from_millis(10));
    assert_eq!(c.take(), "BC0");
}

#[test]
fn port_conditions_and_port_branches() {
    let mut c = Conv::referenced();
    store(
        &mut c,
        &[
            "o0,0,1,3",                     // 0: user input 0 set: jump to 3
            "p0,128,170",                   // 1: user outputs 0xAA
            "3 0,2",                        // 2: to 4
            "p2,0,1",                       // 3: spindle on
            "60,2,1",                       // 4: next move ends on input 1 = 1
            "00,100,0,100,4000,1000,0,100", // 5: z += 4000 (or less)
            "9",
        ],
    );
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.ask("@0b2"), "062", "no spindle");
    assert_eq!(c.position(), [0, 0, 4000]);
    c.send("@0S");
    c.wait(Duration::from_secs(1));
    c.set("in0.1", true);
    assert_eq!(c.next_reply(MINUTE).expect("end").0, "0");
    let z = c.position()[2];
    assert!(z > 4000 && z < 8000, "{z}");
    c.set("in0.0", true);
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.ask("@0b2"), "063", "spindle on");
    assert_eq!(c.position()[2], z, "input 1 is set: the move ends at once");
    assert!(c.sim.describe(c.now).contains("out user AA"));
}

#[test]
fn a_stopped_program_resumes_and_a_broken_one_reports_its_error() {
    let mut c = Conv::referenced();
    store(
        &mut c,
        &[
            "04000,2000,0,100,0,100,0,100",
            "00,100,0,100,100,1000,0,100",
            "9",
        ],
    );
    c.send("@0S");
    c.wait(Duration::from_millis(500));
    c.send_bytes(&[0xFD]);
    assert_eq!(c.next_reply(MINUTE).expect("stop").0, "F");
    // Start goes on with the move and the rest of the program.
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position(), [4000, 0, 100]);
    // A run that needs a reference ends with `R`.
    c.expect("@07", "0");
    let mut unreferenced = Conv::new();
    unreferenced.expect("@07", "0");
    store(&mut unreferenced, &["0100,2000,0,100,0,100,0,100", "9"]);
    unreferenced.expect("@0S", "R");
}

#[test]
fn a_reference_run_and_settings_inside_a_program() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    store(
        &mut c,
        &[
            "d4000,4000,4000",
            "77",
            "j500",
            "J200",
            "0500,3000,0,100,0,100,0,100",
            "9",
        ],
    );
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position(), [500, 0, 0]);
    assert_eq!(c.physical()[..3], [500.0, 0.0, 0.0]);
}

#[test]
fn the_start_key_runs_the_program_without_an_answer() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    store(&mut c, &["133", "9"]);
    c.press("start");
    c.wait(Duration::from_millis(10));
    assert_eq!(c.take(), "!", "the sync character only");
}

/// A pause of a converted G-code job (M0/M6) is `o1,3,0,0`: branch to
/// itself while the start key (port 1 bit 3) reads released. `press start`
/// holds the key down as a finger does, so the loop sees it and the program
/// goes on; the key is up again afterwards.
#[test]
fn a_pressed_start_key_ends_a_program_waiting_for_it() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    store(&mut c, &["o1,3,0,0", "133", "9"]);
    c.send("@0S");
    c.wait(Duration::from_millis(500));
    assert_eq!(c.take(), "", "waiting for the start key");
    c.press("start");
    assert_eq!(c.sim.input_level("start"), Some(true), "held down");
    c.wait(Duration::from_millis(10));
    // The sync character, then the program's end answers `@0S`.
    assert_eq!(c.take(), "!0", "the loop saw the key and went on");
    c.wait(super::super::controls::KEY_HOLD);
    assert_eq!(c.sim.input_level("start"), Some(false), "let go");
}

#[test]
fn watched_inputs_abort_a_run() {
    let mut c = Conv::referenced();
    // Abort when user input 0 goes on; error signal on user output bit 7.
    c.expect("@0IA0,1,0", "0");
    c.expect("@0Ia0,128,128", "0");
    c.expect("@0IN0,2,0", "0");
    store(&mut c, &["010000,2000,0,100,0,100,0,100", "9"]);
    c.send("@0S");
    c.wait(Duration::from_millis(500));
    assert!(c.sim.describe(c.now).contains("out user 00"));
    c.set("in0.0", true);
    assert_eq!(c.next_reply(MINUTE).expect("abort").0, "F");
    c.set("in0.0", false);
    // The external E-stop input: `9`, and the error signal.
    c.send("@0S");
    c.wait(Duration::from_millis(200));
    c.set("in0.1", true);
    assert_eq!(c.next_reply(MINUTE).expect("estop").0, "9");
    assert!(c.sim.describe(c.now).contains("out user 80"));
    c.expect("@0A1,100,0,100,0,100,0,100", "4");
}

#[test]
fn a_delay_cannot_be_cut_short_by_a_soft_stop_but_break_ends_the_run() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    store(&mut c, &["5 10", "133", "9"]);
    c.send("@0S");
    c.wait(Duration::from_millis(300));
    c.send_bytes(&[0xFD]);
    c.press("stop");
    // Manual 3.2.6: the delay runs on.
    let (sync, at) = c.next_reply(MINUTE).expect("sync");
    assert_eq!(sync, "!");
    assert!(at >= Duration::from_millis(690), "{at:?}");
    assert_eq!(c.next_reply(MINUTE).expect("end").0, "0");
    c.send("@0S");
    c.wait(Duration::from_millis(300));
    c.send_bytes(&[0xFF]);
    assert_eq!(c.next_reply(MINUTE).expect("break").0, "F");
    c.silent_for(Duration::from_secs(2));
}

#[test]
fn a_watch_that_is_already_off_target_ends_the_run_before_its_first_command() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.expect("@0IH0,4,4", "0");
    c.expect("@0Ia0,1,1", "0");
    store(&mut c, &["133", "9"]);
    // The external hood input (user input 2) reads open.
    c.expect("@0S", "H");
    assert!(
        c.sim.describe(c.now).contains("out user 01"),
        "error signal"
    );
    c.set("in0.2", true);
    c.send("@0S");
    c.wait(Duration::from_millis(10));
    assert_eq!(c.take(), "!0");
    assert!(c.sim.describe(c.now).contains("out user 00"));
}

/// One command a line (manual 3.1, `docs/protocols.md` isel): a stored line
/// that holds two, or an LF inside it, is one malformed line, answered with
/// its error and never run as several (issue 37).
#[test]
fn a_stored_line_with_more_than_one_command_is_refused_not_run_as_several() {
    for line in ["z1 77", "77 9", "7 7\nm100000,900,0,900,0,900,0,900"] {
        let mut c = Conv::referenced();
        c.expect("@0i", "0");
        let mut bytes = line.as_bytes().to_vec();
        bytes.push(b'\r');
        c.send_bytes(&bytes);
        let (reply, _) = c.next_reply(MINUTE).expect("reply");
        assert_ne!(reply, "0", "{line:?}");
        // The transfer ended with it: nothing stored, nothing runs.
        c.expect("@0S", "G");
        assert_eq!(c.position(), [0, 0, 0], "{line:?}");
    }
}
