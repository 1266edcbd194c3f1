//! End to end: an isel circle of arbitrary angles, computed by `jogterm arc`
//! and run by `jogterm send` on the real `jogterm sim --protocol isel --pty`,
//! stops within one step of its end before any absolute move (decision 12:
//! `B` counts the controller's single-axis steps, and the simulator walks
//! them).

use std::process::Command;

use crate::sim_process;
use sim_process::{JOGTERM, SimProcess, text};

/// 20° to 70° CCW at R = 1000 steps: from (940, 342) to (342, 940) around
/// the centre. The walk moves each axis monotonically within a quadrant,
/// so it takes (940 - 342) + (940 - 342) = 1196 single-axis steps; the
/// manual's formula 4 R (E - A) / pi gives 1111, which a controller stops
/// after about 60 steps short of the end.
const HAND_COUNT: i64 = 1196;

/// The position `@0P` reports last in `jogterm send`'s output.
fn last_xy(stdout: &str) -> (i64, i64) {
    let line = stdout
        .lines()
        .rfind(|l| l.starts_with("<< 0 X="))
        .unwrap_or_else(|| panic!("no position in {stdout}"));
    let value = |axis: &str| -> i64 {
        let tail = line.split(axis).nth(1).unwrap_or_else(|| panic!("{line}"));
        let word = tail.split_whitespace().next().unwrap_or_default();
        word.parse().unwrap_or_else(|_| panic!("{line}"))
    };
    (value("X="), value("Y="))
}

/// On a simulator ten times faster than real time: where a move ends does
/// not depend on the scale.
#[test]
fn a_circle_of_arbitrary_angles_stops_within_a_step_of_its_end() {
    let arc = Command::new(JOGTERM)
        .args([
            "arc", "--radius", "1000", "--start", "20", "--end", "70", "--ccw", "--speed", "4000",
        ])
        .output()
        .expect("jogterm arc runs");
    let lines = text(&arc.stdout);
    assert!(arc.status.success(), "{lines}{}", text(&arc.stderr));
    let mut it = lines.lines();
    let (f, y) = (it.next().unwrap_or_default(), it.next().unwrap_or_default());
    assert_eq!(f, "@0f-1");
    let params: Vec<&str> = y.trim_start_matches("@0y").split(',').collect();
    assert_eq!(params.get(3..), Some(&["940", "342", "-1", "1"][..]), "{y}");
    let b: i64 = params[0].parse().expect("B");
    assert!(
        (b - HAND_COUNT).abs() <= 1,
        "B = {b}, the walk takes {HAND_COUNT}"
    );

    // The simulator walks B iterations, whether B came from jogterm or by
    // hand, and stops where the walk does: (4000, 4000) + (342 - 940,
    // 940 - 342).
    let by_hand = format!("@0y{HAND_COUNT},{}", params[1..].join(","));
    let sim = SimProcess::options("isel")
        .time_scale(sim_process::LOGIC_SCALE)
        .start();
    for circle in [y.to_string(), by_hand] {
        let out = sim.run(&[
            "send",
            "@07",
            "@0d10000,10000,10000",
            "@0R7",
            "@0A 4000,4000,4000,4000,0,900,0,900",
            f,
            &circle,
            "@0P",
        ]);
        let stdout = text(&out.stdout);
        assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
        let (x, y) = last_xy(&stdout);
        let want = (4000 + 342 - 940, 4000 + 940 - 342);
        assert!(
            (x - want.0).abs() <= 1 && (y - want.1).abs() <= 1,
            "{circle} ends at ({x}, {y}), the arc at {want:?}\n{stdout}"
        );
    }
}
