//! Program languages: parser, linter, formatter, path, incremental re-parse.

use crate::fuzz_checks;
use crate::fuzz_inputs;

use proptest::prelude::*;

proptest! {
    #![proptest_config(fuzz_inputs::config())]

    #[test]
    fn program(data in fuzz_inputs::inputs("program")) {
        fuzz_checks::program::program(&data);
    }
}

#[test]
fn every_program_seed_passes() {
    for seed in fuzz_inputs::seeds("program") {
        fuzz_checks::program::program(&seed);
    }
}

// Found by fuzzing.

/// A line that ends with a CR of its own (the file had CR CR LF) was saved
/// by `Program::text` with a plain LF, and read back without its CR.
#[test]
fn text_keeps_a_line_that_ends_with_a_cr() {
    use jogterm::program::{Language, Program};
    for language in Language::ALL {
        let program = Program::parse(language, "77\r\r\n9\r\n");
        assert_eq!(program.line(0).map(|l| l.text()), Some("77\r"));
        assert_eq!(Program::parse(language, &program.text()), program);
    }
    fuzz_checks::program::program(b"\x0077 ; x\r\r\n\r\r\n9\n");
}

/// `#;c` is the command `#` (which does not parse) and a trailing comment;
/// the formatter wrote `# ;c`, which is a whole-line comment, so a line that
/// blocks an upload turned into one that is silently left out.
#[test]
fn format_keeps_a_bare_hash_a_command() {
    use jogterm::program::{Language, Program, format};
    for language in Language::ALL {
        let program = Program::parse(language, "#;S150\n9\n");
        assert!(program.line(0).is_some_and(|l| l.statement().is_some()));
        let formatted = format(&program);
        assert_eq!(formatted, "#;S150\n9\n");
        assert_eq!(
            Program::parse(language, &formatted).items(),
            program.items()
        );
    }
}
