//! The import's output does not change when the import is made faster
//! (docs/gcode.md, "Performance"): the bench's CAM file of 100 000 lines
//! (`benches/support/cam.rs`, the same generator) converts to the same
//! isel and EMCU program text, and its job to the same pieces between its
//! tool changes, as the code before the optimisations of issue 41 item 7
//! did. The hashes are FNV-1a of the text, as the bench prints them; the
//! whole-program ones are those the bench printed at 100 000 lines before
//! that work (docs/gcode.md, `d8d8f34943a3c096`, `d29039e931859cf7`); the
//! pieces' ones (three pieces: two tool changes) with the plan as it was
//! then, copies of the ops (`da2317f`).

#[path = "../../benches/support/cam.rs"]
mod cam;

use jogterm::gcode::output::Header;
use jogterm::gcode::waits::convert_piece;
use jogterm::gcode::{Target, import};

use cam::{cam_file, fnv, machine};

/// FNV-1a of each piece's converted program, then of the list of them.
fn pieces_hash(
    i: &jogterm::gcode::Import,
    profile: &jogterm::config::Profile,
    target: Target,
) -> (usize, u64) {
    let header = Header {
        file: "bench.nc".into(),
        profile: profile.name.clone(),
        system: i.summary.system.to_string(),
        zero: i.summary.zero,
    };
    let mut all = String::new();
    for k in 0..i.plan.segments() {
        let dz = k as f64 * 0.25;
        let piece = convert_piece(
            &i.plan,
            &i.toolpath,
            k,
            (dz - 0.25, dz),
            profile,
            target,
            &header,
        )
        .unwrap_or_else(|e| panic!("piece {k}: {:?}", &e[..e.len().min(3)]));
        all.push_str(&format!("{:016x}\n", fnv(&piece.text("bench.nc"))));
    }
    (i.plan.segments(), fnv(&all))
}

#[test]
fn the_bench_file_converts_to_the_same_programs_as_before() {
    let text = cam_file(100_000);
    for (name, target, whole, pieces) in [
        (
            "default",
            Target::Isel,
            0xd8d8_f349_43a3_c096_u64,
            (3, 0xe69f_b3bb_d5b0_9e3a),
        ),
        (
            "emcu",
            Target::Emcu,
            0xd290_39e9_3185_9cf7,
            (3, 0xfdb4_79c4_b7a7_b3c2),
        ),
    ] {
        let (profile, offsets) = machine(name);
        let i = import(&text, "bench.nc", &profile, &offsets, target)
            .unwrap_or_else(|e| panic!("{name}: {:?}", &e[..e.len().min(3)]));
        let got = fnv(&i.program.text("bench.nc"));
        let got_pieces = pieces_hash(&i, &profile, target);
        assert_eq!(got, whole, "{name}: the whole program's text");
        assert_eq!(got_pieces, pieces, "{name}: the pieces' programs");
    }
}
