//! The formatter, and properties of parser, formatter, linter and path on
//! generated and arbitrary text: `parse(format(p)) == p`, formatting is
//! idempotent, and nothing panics on any input.

use jogterm::axis::AxisSet;
use jogterm::program::{AxisLimit, Language, LintConfig, Program, Start, format, lint, path_with};
use proptest::prelude::*;

#[test]
fn canonical_spelling_one_command_per_line_comments_kept() {
    let text = "\
; Bohrbild   \r
  # zwei Reihen
\t7 7
M 1000,900,0,900,0,900,0,900   ;  Anfang  
   0 50,900,0,900,-500,900,500,900
3 3,-2 ; Reihe
F1
y400,1500,119,-141,141,-1,-1
m1x,900   ; kaputt, bleibt stehen


9";
    let expected = "\
; Bohrbild
# zwei Reihen
77
m1000,900,0,900,0,900,0,900 ;  Anfang
050,900,0,900,-500,900,500,900
33,-2 ; Reihe
f-1
y400,1500,119,-141,141,-1,-1
m1x,900 ; kaputt, bleibt stehen


9
";
    let program = Program::parse(Language::Isel, text);
    assert_eq!(format(&program), expected);
    let job = Program::parse(
        Language::Emcu,
        "  #S0150\n#E1,0800 ;fast\n\nL1,y5,x-7\n# end\n",
    );
    assert_eq!(format(&job), "#S150\n#E1,800 ;fast\n\nL1,x-7,y5\n# end\n");
}

/// Numbers around the edges of the fields: small, negative, large.
fn number() -> impl Strategy<Value = i64> {
    prop_oneof![
        0i64..20,
        -20i64..0,
        100i64..50_000,
        Just(128),
        Just(-1),
        -9_000_000i64..9_000_000,
    ]
}

fn comment() -> impl Strategy<Value = String> {
    ("[;#]", "[ a-zA-Zäöü0-9,;#@]{0,12}").prop_map(|(marker, text)| {
        if marker == "#" {
            format!("# {text}")
        } else {
            format!(";{text}")
        }
    })
}

fn isel_command() -> impl Strategy<Value = String> {
    let code = prop::sample::select(vec![
        "0", "1", "2", "3", "5", "6", "7", "9", "d", "e", "f", "g", "j", "J", "m", "n", "N", "o",
        "p", "T", "w", "y", "z", "F", "M", "O", "P", "W", "Y", "Z",
    ]);
    (
        code,
        " {0,2}",
        prop::collection::vec(number(), 0..9),
        prop::option::of(comment()),
    )
        .prop_map(|(code, space, numbers, comment)| {
            let params: Vec<String> = numbers.iter().map(i64::to_string).collect();
            let mut line = format!("{code}{space}{}", params.join(","));
            if let Some(c) = comment {
                line.push(' ');
                line.push_str(&c);
            }
            line
        })
}

fn emcu_command() -> impl Strategy<Value = String> {
    let axis = ("[xyzXYZ]", -1_000_000i64..1_000_000).prop_map(|(a, n)| format!("{a}{n}"));
    prop_oneof![
        (0u32..12_000).prop_map(|n| format!("#S{n}")),
        (0u32..11, 0u32..12_000).prop_map(|(s, n)| format!("#E{s},{n}")),
        (0u32..12_000).prop_map(|n| format!("#R{n}")),
        "[XYZ]{1,3}".prop_map(|a| format!("$H{a}")),
        (0u32..11, prop::collection::vec(axis, 1..4))
            .prop_map(|(s, axes)| format!("L{s},{}", axes.join(","))),
        (0u32..4, 0u32..3).prop_map(|(o, v)| format!("A{o},{v}")),
        (0u32..12_000).prop_map(|n| format!("W{n}")),
        (0u32..3).prop_map(|n| format!("&V{n}")),
        prop::sample::select(vec![
            "@R", "@V", "@X", "@LX", "@B", "@S", "@A", "@C", "@F", "@J"
        ])
        .prop_map(String::from),
    ]
}

fn program(command: impl Strategy<Value = String>) -> impl Strategy<Value = String> {
    let line = prop_oneof![
        3 => (" {0,2}", command, "[ \t]{0,2}").prop_map(|(a, c, b)| format!("{a}{c}{b}")),
        1 => comment(),
        1 => "[ \t]{0,3}",
    ];
    (prop::collection::vec(line, 0..25), "(\n|\r\n)").prop_map(|(lines, end)| lines.join(&end))
}

fn limited() -> LintConfig {
    let mut config = LintConfig::new(AxisSet::XYZ);
    config.limits = [Some(AxisLimit::steps(-1000, 100_000)); 4];
    config.budget = 20_000;
    config
}

fn round_trip(language: Language, text: &str) -> Result<(), TestCaseError> {
    let program = Program::parse(language, text);
    let formatted = format(&program);
    let again = Program::parse(language, &formatted);
    prop_assert_eq!(again.items(), program.items());
    prop_assert_eq!(format(&again), formatted.clone());
    prop_assert_eq!(again.command_count(), program.command_count());
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn isel_programs_survive_formatting(text in program(isel_command())) {
        round_trip(Language::Isel, &text)?;
    }

    #[test]
    fn emcu_jobs_survive_formatting(text in program(emcu_command())) {
        round_trip(Language::Emcu, &text)?;
    }

    #[test]
    fn generated_programs_lint_and_run_without_panicking(text in program(isel_command())) {
        let program = Program::parse(Language::Isel, &text);
        let diagnostics = lint(&program, &limited());
        for d in &diagnostics {
            let line = program.line(d.span.line).map(|l| l.text()).unwrap_or_default();
            prop_assert!(d.span.start <= d.span.end);
            prop_assert!(d.span.end <= line.len() || d.span.line + 1 >= program.lines().len().max(1));
        }
        let path = path_with(&program, &Start::at_zero(AxisSet::XYZA), 5_000);
        prop_assert!(path.executed <= 5_000);
    }

    #[test]
    fn arbitrary_text_never_panics(text in any::<String>()) {
        for language in Language::ALL {
            let program = Program::parse(language, &text);
            // Every span can slice its line (whole characters).
            for d in lint(&program, &limited()) {
                if let Some(line) = program.line(d.span.line) {
                    prop_assert!(line.text().get(d.span.cols()).is_some(), "{:?}", d);
                }
            }
            for line in program.lines() {
                if let Some(s) = line.statement() {
                    prop_assert!(line.text().get(s.code.clone()).is_some());
                    if let Err(e) = &s.command {
                        prop_assert!(line.text().get(e.cols.clone()).is_some(), "{:?}", e);
                    }
                }
            }
            let _ = path_with(&program, &Start::at_zero(AxisSet::XYZ), 2_000);
            round_trip(language, &text)?;
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let text = String::from_utf8_lossy(&bytes);
        for language in Language::ALL {
            let program = Program::parse(language, &text);
            let _ = lint(&program, &limited());
            round_trip(language, &text)?;
        }
    }
}
