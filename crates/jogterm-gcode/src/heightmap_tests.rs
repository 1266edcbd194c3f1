use proptest::prelude::*;

use super::*;
use crate::setup::Setup;

/// The map's work zero (G54), machine mm.
const ZERO: Point = Point {
    x: 10.0,
    y: 20.0,
    z: 30.0,
};

const AREA: Area = Area {
    x0: 0.0,
    y0: 0.0,
    x1: 95.0,
    y1: 80.0,
};

/// A tilted plane, machine Z of the surface at work (x, y).
fn plane(x: f64, y: f64) -> f64 {
    29.9 + 0.004 * x - 0.003 * y
}

fn map_of(area: Area, spacing: f64, surface: impl Fn(f64, f64) -> f64) -> HeightMap {
    let grid = Grid::new(area, spacing).expect("a grid");
    let z: Vec<f64> = grid.points().map(|(x, y)| surface(x, y)).collect();
    HeightMap::new(
        1_796_029_200,
        "isel simulator",
        System::G54,
        ZERO,
        area,
        spacing,
        &z,
    )
    .expect("a map")
}

fn fit() -> Fit {
    Fit {
        profile: "isel simulator".into(),
        step_mm: (0.0025, 0.0025),
        chord_tolerance: 0.01,
        z_max: Some(80.0),
    }
}

fn setup() -> Setup {
    let mut setup = Setup {
        default_units: Some(crate::setup::Units::Mm),
        ..Setup::default()
    };
    setup.zeros[0] = ZERO;
    setup
}

fn toolpath(text: &str) -> Toolpath {
    crate::interpret(text, &setup()).expect("G-code that interprets")
}

fn feed_points(path: &Toolpath) -> Vec<(Point, Point)> {
    path.ops
        .iter()
        .filter_map(|op| match op {
            Op::Line(l) => Some((l.from, l.to)),
            _ => None,
        })
        .collect()
}

#[test]
fn the_grid_ends_at_the_areas_edge_even_where_it_is_closer_than_the_spacing() {
    let grid = Grid::new(AREA, 10.0).expect("grid");
    assert_eq!(
        grid.xs,
        [
            0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 95.0
        ]
    );
    assert_eq!(grid.ys.len(), 9);
    assert_eq!(grid.points().nth(11), Some((0.0, 10.0)), "row-major");
    assert_eq!(grid.len(), 99);
}

#[test]
fn bilinear_is_exact_on_a_plane_and_at_the_grid_points() {
    let surface = map_of(AREA, 10.0, plane).validate().expect("valid");
    for (x, y) in [
        (0.0, 0.0),
        (95.0, 80.0),
        (3.3, 71.9),
        (92.5, 4.0),
        (50.0, 40.0),
    ] {
        let z = surface.z_at(x, y).expect("inside");
        assert!((z - plane(x, y)).abs() < 1e-9, "{x} {y}: {z}");
    }
    // A surface that is no plane: the grid points' own heights, exactly.
    let bumpy = |x: f64, y: f64| 30.0 + (x * 0.1).sin() * (y * 0.07).cos();
    let surface = map_of(AREA, 10.0, bumpy).validate().expect("valid");
    for (x, y) in surface.grid().points().collect::<Vec<_>>() {
        assert_eq!(surface.z_at(x, y), Some(bumpy(x, y)));
    }
    // Between them, bilinear: the middle of a cell is its corners' mean.
    let mean =
        (bumpy(10.0, 20.0) + bumpy(20.0, 20.0) + bumpy(10.0, 30.0) + bumpy(20.0, 30.0)) / 4.0;
    let z = surface.z_at(15.0, 25.0).expect("inside");
    assert!((z - mean).abs() < 1e-12);
    assert!((surface.correction(15.0, 25.0).expect("inside") - (mean - 30.0)).abs() < 1e-12);
}

#[test]
fn outside_the_area_there_is_no_surface_not_a_clamped_one() {
    let surface = map_of(AREA, 10.0, plane).validate().expect("valid");
    assert!(surface.z_at(95.0, 80.0).is_some());
    assert_eq!(surface.z_at(95.01, 40.0), None);
    assert_eq!(surface.z_at(-0.01, 40.0), None);
    assert_eq!(surface.z_at(40.0, 80.001), None);
    assert_eq!(surface.z_at(40.0, -1.0), None);
}

#[test]
fn lines_are_cut_at_the_grid_lines_and_into_pieces_no_longer_than_the_spacing() {
    let surface = map_of(AREA, 10.0, plane).validate().expect("valid");
    // Work X5 Y5 to X90 Y77: 111 mm in X/Y, crossing 9 columns and 7 rows.
    let path = toolpath("G0 X5 Y5 Z1\nG1 Z-0.2 F300\nG1 X90 Y77\nM30\n");
    let (mapped, applied) = surface.apply(&path, &fit()).expect("applies");
    let pieces = feed_points(&mapped);
    // The plunge, then the diagonal.
    let diagonal = &pieces[1..];
    assert!(diagonal.len() >= 17, "{}", diagonal.len());
    for (from, to) in diagonal {
        let xy = (to.x - from.x).hypot(to.y - from.y);
        assert!(xy <= 10.0 + 1e-9, "{xy}");
        // No piece crosses a grid line: both ends in one cell.
        let cell_of = |v: f64, w: f64| {
            ((v - ZERO.x) / 10.0).floor() == ((w - ZERO.x) / 10.0).floor()
                || ((w - ZERO.x) % 10.0).abs() < 1e-9
        };
        assert!(cell_of(from.x, to.x), "{from:?} {to:?}");
    }
    assert_eq!(diagonal.last().map(|p| (p.1.x, p.1.y)), Some((100.0, 97.0)));
    assert_eq!(applied.feed_moves, 2);
    assert_eq!(applied.feed_segments, pieces.len());
    // Every end on the surface, 0.2 below it.
    for (_, to) in diagonal {
        let expected = plane(to.x - ZERO.x, to.y - ZERO.y) - 0.2;
        assert!((to.z - expected).abs() < 1e-9);
    }
    // A short move stays one piece; a plunge is never cut.
    let path = toolpath("G0 X5 Y5 Z1\nG1 Z-0.2 F300\nG1 X7 Y6\nM30\n");
    let (mapped, _) = surface.apply(&path, &fit()).expect("applies");
    assert_eq!(feed_points(&mapped).len(), 2);
}

#[test]
fn an_arc_becomes_segments_on_the_surface() {
    let bumpy = |x: f64, y: f64| 30.0 + 0.2 * (x * 0.1).sin() * (y * 0.07).cos();
    let surface = map_of(AREA, 10.0, bumpy).validate().expect("valid");
    // A helix: a full turn of radius 20 about work X50 Y40, Z -0.2 to -1.
    let path = toolpath("G0 X70 Y40 Z1\nG1 Z-0.2 F300\nG3 X70 Y40 I-20 J0 Z-1\nM30\n");
    assert!(path.ops.iter().any(|op| matches!(op, Op::Arc(_))));
    let (mapped, applied) = surface.apply(&path, &fit()).expect("applies");
    assert!(!mapped.ops.iter().any(|op| matches!(op, Op::Arc(_))));
    assert_eq!(applied.arcs_as_segments, 1);
    let pieces = feed_points(&mapped);
    let helix = &pieces[1..];
    assert!(helix.len() > 40, "{}", helix.len());
    let (cx, cy) = (ZERO.x + 50.0, ZERO.y + 40.0);
    for (i, (from, to)) in helix.iter().enumerate() {
        let xy = (to.x - from.x).hypot(to.y - from.y);
        assert!(xy <= 10.0 + 1e-9);
        // Inside the circle by at most the chord tolerance.
        let r = (to.x - cx).hypot(to.y - cy);
        assert!((20.0 - 0.01 - 1e-9..=20.0 + 1e-9).contains(&r), "{r}");
        // The helix' own Z at this point of the turn, plus the surface.
        let (wx, wy) = (to.x - ZERO.x, to.y - ZERO.y);
        let turned = if i + 1 == helix.len() {
            1.0
        } else {
            (to.y - cy)
                .atan2(to.x - cx)
                .rem_euclid(2.0 * std::f64::consts::PI)
                / (2.0 * std::f64::consts::PI)
        };
        let job_z = -0.2 - 0.8 * turned;
        let expected = surface.z_at(wx, wy).expect("inside") + job_z;
        // Points between a chord's ends lie on the chord, a little inside
        // the turn's angle: its Z is the chord's.
        assert!((to.z - expected).abs() < 1e-3, "{to:?}: {expected}");
    }
    let end = helix.last().map(|p| p.1).expect("an end");
    assert!((end.z - (bumpy(70.0, 40.0) - 1.0)).abs() < 1e-9);
}

#[test]
fn rapids_are_raised_by_the_highest_correction_and_never_past_the_top_of_z() {
    let surface = map_of(AREA, 10.0, plane).validate().expect("valid");
    let (_, max) = surface.correction_range();
    // plane(95, 0) = 30.28: the highest point, 0.28 above the zero's Z.
    assert!((max - 0.28).abs() < 1e-9);
    let path = toolpath("G0 X5 Y5 Z5\nG1 Z-0.1 F300\nG0 Z5\nG53 G0 Z80\nG0 X200 Y200\nM30\n");
    let (mapped, applied) = surface.apply(&path, &fit()).expect("rapids anywhere");
    assert!((applied.rapids_raised - 0.28).abs() < 1e-9);
    let rapids: Vec<f64> = mapped
        .ops
        .iter()
        .filter_map(|op| match op {
            Op::Rapid(r) => Some(r.to.z),
            _ => None,
        })
        .collect();
    let raised = 35.0 + 0.28;
    assert!((rapids[0] - raised).abs() < 1e-9);
    assert!((rapids[1] - raised).abs() < 1e-9);
    assert_eq!(rapids[2], 80.0, "the top of Z's travel");
    assert_eq!(rapids[3], 80.0, "outside the map: a rapid, not a cut");
    // A surface all below the zero: rapids stay where the file put them.
    let low = map_of(AREA, 10.0, |_, _| 29.0).validate().expect("valid");
    let (mapped, applied) = low.apply(&path, &fit()).expect("applies");
    assert_eq!(applied.rapids_raised, 0.0);
    assert_eq!(mapped.safe_height(), path.safe_height());
}

#[test]
fn a_cut_outside_the_area_is_an_error_at_its_line() {
    let surface = map_of(AREA, 10.0, plane).validate().expect("valid");
    let path = toolpath("G0 X5 Y5 Z1\nG1 Z-0.2 F300\nG1 X50\nG1 X96\nM30\n");
    let errors = surface.apply(&path, &fit()).expect_err("outside");
    assert_eq!(errors.len(), 1);
    assert_eq!(errors[0].origin.line, 4);
    assert!(
        errors[0].message.contains("X 96.000 Y 5.000")
            && errors[0]
                .message
                .contains("outside the height map's area X 0 .. 95, Y 0 .. 80"),
        "{}",
        errors[0].message
    );
    // An arc whose bulge leaves the area, its ends inside.
    let path = toolpath("G0 X2 Y40 Z1\nG1 Z-0.2 F300\nG2 X2 Y60 I0 J10\nM30\n");
    let errors = surface.apply(&path, &fit()).expect_err("the bulge");
    assert_eq!(errors[0].origin.line, 3);
}

#[test]
fn a_cut_from_where_the_job_starts_is_refused() {
    let surface = map_of(AREA, 10.0, plane).validate().expect("valid");
    let path = toolpath("G1 X5 Y5 Z-1 F300\nM30\n");
    let errors = surface.apply(&path, &fit()).expect_err("unknown start");
    assert_eq!(errors[0].origin.line, 1);
    assert!(errors[0].message.contains("before the file names X and Y"));
}

#[test]
fn a_map_of_another_work_offset_zero_or_machine_is_refused() {
    let map = map_of(AREA, 10.0, plane);
    let path = toolpath("G0 X5 Y5 Z1\nG1 Z-0.2 F300\nM30\n");
    let mut g55 = map.clone();
    g55.work_offset = "G55".into();
    let errors = g55
        .validate()
        .expect("valid")
        .apply(&path, &fit())
        .expect_err("G55");
    assert!(
        errors[0]
            .message
            .contains("probed in work offset G55, and the job runs in G54"),
        "{}",
        errors[0].message
    );
    // A file that selects another offset, at the line that selects it.
    let mut two = setup();
    two.zeros[1] = ZERO;
    let path2 = crate::interpret("G0 X5 Y5 Z1\nG55\nG0 X6\nM30\n", &two).expect("interprets");
    let errors = map
        .validate()
        .expect("valid")
        .apply(&path2, &fit())
        .expect_err("G55 line");
    assert_eq!(errors[0].origin.line, 2, "{errors:?}");
    // X zero 0.01 mm off (four steps): refused, with how far.
    let mut moved = map.clone();
    moved.work_zero_machine_mm.x += 0.01;
    let errors = moved
        .validate()
        .expect("valid")
        .apply(&path, &fit())
        .expect_err("moved");
    assert!(
        errors[0]
            .message
            .contains("X zero at machine 10.0000 mm, the map's at 10.0100 mm (-0.0100 mm)"),
        "{}",
        errors[0].message
    );
    // Within a step: the same zero.
    let mut near = map.clone();
    near.work_zero_machine_mm.y += 0.002;
    assert!(near.validate().expect("valid").apply(&path, &fit()).is_ok());
    // A Z zero touched again (another tool) is no refusal: it moves the cut.
    let mut z = map.clone();
    z.work_zero_machine_mm.z -= 1.5;
    let (mapped, applied) = z
        .validate()
        .expect("valid")
        .apply(&path, &fit())
        .expect("Z moved");
    assert!((applied.z_zero_moved - 1.5).abs() < 1e-9);
    let plunge = feed_points(&mapped)[0].1;
    assert!((plunge.z - (plane(5.0, 5.0) + 1.5 - 0.2)).abs() < 1e-9);
    let mut other = fit();
    other.profile = "mill".into();
    let errors = map
        .validate()
        .expect("valid")
        .apply(&path, &other)
        .expect_err("profile");
    assert!(
        errors[0]
            .message
            .contains("probed on profile \"isel simulator\", not \"mill\"")
    );
}

#[test]
fn validation_names_the_field_and_what_was_expected() {
    let good = map_of(AREA, 10.0, plane);
    let fields = |map: &HeightMap| -> Vec<String> {
        map.validate()
            .expect_err("invalid")
            .iter()
            .map(|e| e.field.clone())
            .collect()
    };
    let mut m = good.clone();
    m.version = 2;
    m.probed_at = "yesterday".into();
    m.work_offset = "G53".into();
    assert_eq!(fields(&m), ["version", "probed_at", "work_offset"]);
    let mut m = good.clone();
    m.points.pop();
    let errors = m.validate().expect_err("short");
    assert_eq!(
        errors[0].to_string(),
        "points: expected 11 x 9 = 99 points (columns x0, x0 + spacing, … x1; rows likewise), found 98"
    );
    let mut m = good.clone();
    m.points[12].x = 21.5;
    m.points[13].z = f64::NAN;
    let errors = m.validate().expect_err("off the grid");
    assert_eq!(
        errors[0].to_string(),
        "points[12].x: expected 10 (column 1 of the grid at spacing 10, row-major), found 21.5"
    );
    assert_eq!(errors[1].field, "points[13].z");
    let mut m = good.clone();
    m.spacing = 0.0;
    assert_eq!(fields(&m), ["spacing"]);
    let mut m = good.clone();
    m.spacing = 0.001;
    assert!(
        m.validate().expect_err("huge")[0]
            .message
            .contains("more than 1000000")
    );
    let mut m = good.clone();
    m.area.x1 = -1.0;
    m.work_zero_machine_mm.z = f64::INFINITY;
    assert_eq!(fields(&m), ["work_zero_machine_mm.z", "area.x1"]);
    assert!(HeightMap::new(0, "p", System::G54, ZERO, AREA, 10.0, &[1.0; 98]).is_err());
}

#[test]
fn the_file_format_reads_as_the_docs_show_it() {
    let text = r#"{
      "version": 1,
      "probed_at": "2026-12-07T09:00:00Z",
      "profile": "isel simulator",
      "work_offset": "G54",
      "work_zero_machine_mm": {"x": 10.0, "y": 20.0, "z": 30.0},
      "area": {"x0": 0.0, "y0": 0.0, "x1": 10.0, "y1": 5.0},
      "spacing": 10.0,
      "points": [{"x": 0.0, "y": 0.0, "z": 29.95}, {"x": 10.0, "y": 0.0, "z": 30.05},
                 {"x": 0.0, "y": 5.0, "z": 29.9}, {"x": 10.0, "y": 5.0, "z": 30.0}]
    }"#;
    let map: HeightMap = serde_json::from_str(text).expect("the format");
    let surface = map.validate().expect("valid");
    assert_eq!(surface.probed_at_unix(), 1_796_634_000);
    let (min, max) = surface.correction_range();
    assert!((min + 0.1).abs() < 1e-9 && (max - 0.05).abs() < 1e-9);
    let back: HeightMap =
        serde_json::from_str(&serde_json::to_string(&map).expect("writes")).expect("reads");
    assert_eq!(back, map);
}

#[test]
fn rfc3339_times_round_trip_and_offsets_count() {
    assert_eq!(rfc3339(0), "1970-01-01T00:00:00Z");
    assert_eq!(rfc3339(1_796_634_000), "2026-12-07T09:00:00Z");
    assert_eq!(rfc3339(951_782_400), "2000-02-29T00:00:00Z");
    for t in [0, 951_782_400, 1_796_634_000, 4_102_444_799] {
        assert_eq!(parse_rfc3339(&rfc3339(t)), Some(t));
    }
    assert_eq!(
        parse_rfc3339("2026-12-07T10:00:00.25+01:00"),
        Some(1_796_634_000)
    );
    assert_eq!(
        parse_rfc3339("2026-12-07T08:30:00-00:30"),
        Some(1_796_634_000)
    );
    for bad in [
        "2026-12-07",
        "2026-02-29T00:00:00Z",
        "2026-12-07T09:00:00",
        "2026-13-01T00:00:00Z",
        "2026-12-07T09:00:00.Z",
    ] {
        assert_eq!(parse_rfc3339(bad), None, "{bad}");
    }
}

/// Found by the property below: a line all but parallel to Y crosses the
/// grid's rows a spacing apart, and the piece between two rows is longer
/// than the spacing by nanometres. It stays one piece (the split's slack),
/// and every piece is within that slack.
#[test]
fn a_line_nearly_along_a_grid_line_is_cut_at_the_rows_only() {
    let spacing = 16.27796117810137;
    let map = map_of(AREA, spacing, |_, _| 25.0);
    let surface = map.validate().expect("valid");
    let path = toolpath("G0 X1 Y1 Z5\nG1 X1.0006684138173703 Y44.349491792390154 Z0 F500\n");
    let (mapped, _) = surface.apply(&path, &fit()).expect("inside");
    let pieces: Vec<f64> = mapped
        .ops
        .iter()
        .filter_map(|op| match op {
            Op::Line(l) => Some((l.to.x - l.from.x).hypot(l.to.y - l.from.y)),
            _ => None,
        })
        .collect();
    assert_eq!(pieces.len(), 3, "{pieces:?}");
    assert!(
        pieces.iter().all(|xy| *xy <= spacing * (1.0 + 1e-9)),
        "{pieces:?}"
    );
    assert!(
        pieces[1] > spacing,
        "the middle piece is over by nanometres: {pieces:?}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]
    /// Bilinear interpolation reproduces a plane: every point a random
    /// line inside the area becomes lies at the job's Z plus the plane
    /// less the zero's Z.
    #[test]
    fn on_a_tilted_plane_every_point_is_the_jobs_z_plus_the_plane(
        a in 25.0..35.0f64,
        bx in -0.05..0.05f64,
        by in -0.05..0.05f64,
        spacing in 1.5..30.0f64,
        moves in prop::collection::vec((0.0..95.0f64, 0.0..80.0f64, -3.0..1.0f64), 1..8),
    ) {
        let surface_of = |x: f64, y: f64| a + bx * x + by * y;
        let map = map_of(AREA, spacing, surface_of);
        let surface = map.validate().expect("valid");
        let mut text = String::from("G0 X1 Y1 Z5\n");
        for (x, y, z) in &moves {
            text.push_str(&format!("G1 X{x} Y{y} Z{z} F500\n"));
        }
        let path = toolpath(&text);
        let (mapped, _) = surface.apply(&path, &fit()).expect("inside");
        // The job's Z along each original move, at each output point.
        let originals: Vec<Line> = path.ops.iter().filter_map(|op| match op {
            Op::Line(l) => Some(*l),
            _ => None,
        }).collect();
        for piece in mapped.ops.iter().filter_map(|op| match op {
            Op::Line(l) => Some(*l),
            _ => None,
        }) {
            let (from, to) = (piece.from, piece.to);
            let xy = (to.x - from.x).hypot(to.y - from.y);
            // The split's own slack: a piece between two grid lines is
            // kept whole up to a billionth over the spacing (a line all
            // but parallel to a grid line would otherwise be cut in two
            // for nanometres; `heightmap::apply`).
            prop_assert!(xy <= spacing * (1.0 + 1e-9), "{} > {}", xy, spacing);
            // Each G1 is a line of its own: the piece's origin names it.
            let line = originals.iter().find(|l| l.origin == piece.origin);
            let Some(line) = line else { continue };
            let length = (line.to.x - line.from.x).hypot(line.to.y - line.from.y);
            let t = if length < 1e-12 { 1.0 } else { (to.x - line.from.x).hypot(to.y - line.from.y) / length };
            let job_z = line.from.z + (line.to.z - line.from.z) * t;
            let expected = job_z + surface_of(to.x - ZERO.x, to.y - ZERO.y) - ZERO.z;
            prop_assert!((to.z - expected).abs() < 1e-9, "{:?}: {}", to, expected);
        }
    }
}
