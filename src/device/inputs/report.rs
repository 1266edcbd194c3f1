//! The commissioning report of a walk-test, as Markdown (for a person and a
//! ticket) and JSON (for a tool), from the same values. Pure formatting:
//! `jogterm commission` writes the files.

use std::time::Duration;

use serde_json::{Value, json};

use super::level_word;
use super::walk::{
    InputResult, OutputResult, WalkTest, input_summary, labelled, ms, output_address,
    output_summary,
};

/// What the report says the walk-test was about.
#[derive(Debug, Clone, PartialEq)]
pub struct Meta {
    /// The profile's `name` and `description`.
    pub machine: String,
    pub description: String,
    /// The profile as it was chosen (`--profile`, or the shipped one).
    pub profile: String,
    pub protocol: String,
    pub port: String,
    pub baud: u32,
    /// UTC, `2026-11-21T22:34:01.123456Z`.
    pub date: String,
    /// The longest interval between two readings of any input group.
    pub read_every: Option<Duration>,
}

fn secs(d: Duration) -> f64 {
    (d.as_secs_f64() * 1000.0).round() / 1000.0
}

fn millis(d: Duration) -> f64 {
    (d.as_secs_f64() * 10_000.0).round() / 10.0
}

fn input_json(r: &InputResult) -> Value {
    let c = &r.channel;
    let seen = |s: &Option<super::walk::Seen>| {
        s.as_ref().map(
            |s| json!({"t": secs(s.t), "level": u8::from(s.level), "window_ms": millis(s.window)}),
        )
    };
    json!({
        "input": c.name,
        "label": c.label(),
        "address": c.address,
        "role": format!("{:?}", c.role).to_lowercase(),
        "result": r.verdict.word(),
        "active_level": r.active_level.map(u8::from),
        "expected_active_level": u8::from(c.active),
        "resting_level": r.resting.map(u8::from),
        "triggered": seen(&r.triggered),
        "released": seen(&r.released),
        "held_s": match (&r.triggered, &r.released) {
            (Some(a), Some(b)) => Some(secs(b.t.saturating_sub(a.t))),
            _ => None,
        },
        "moved_instead": r.others.iter().map(|o| o.address.clone()).collect::<Vec<_>>(),
        "chatters": r.chattered,
    })
}

fn output_json(o: &OutputResult) -> Value {
    json!({
        "output": o.name,
        "address": output_address(o.output),
        "hazardous": o.hazardous,
        "switched_to": o.switched_to,
        "confirmed": o.confirmed,
        "refused": o.refused,
        "inputs_followed": o.inputs_followed.iter().map(|c| c.address.clone()).collect::<Vec<_>>(),
    })
}

/// The report as JSON.
pub fn json(meta: &Meta, walk: &WalkTest) -> Value {
    let estop = walk.estop().map(|e| {
        json!({
            "circuits": e.circuits.iter().map(input_json).collect::<Vec<_>>(),
            "open_skew_ms": e.open_skew.map(|(m, _, _)| millis(m)),
            "open_skew_min_ms": e.open_skew.map(|(_, lo, _)| millis(lo)),
            "open_skew_max_ms": e.open_skew.map(|(_, _, hi)| millis(hi)),
            "close_skew_ms": e.close_skew.map(millis),
        })
    });
    json!({
        "machine": meta.machine,
        "description": meta.description,
        "profile": meta.profile,
        "protocol": meta.protocol,
        "port": meta.port,
        "baud": meta.baud,
        "date": meta.date,
        "read_every_ms": meta.read_every.map(millis),
        "complete": !walk.ended_early,
        "findings": findings(walk).len(),
        "estop": estop,
        "inputs": walk.inputs.iter().map(input_json).collect::<Vec<_>>(),
        "outputs": walk.outputs.iter().map(output_json).collect::<Vec<_>>(),
    })
}

/// What needs looking into, one line each.
pub fn findings(walk: &WalkTest) -> Vec<String> {
    let circuits = walk
        .estop()
        .map(|e| e.circuits.iter())
        .into_iter()
        .flatten();
    let mut out: Vec<String> = circuits
        .chain(walk.inputs.iter())
        .filter(|r| r.verdict.is_finding() || r.chattered)
        .map(input_summary)
        .collect();
    out.extend(
        walk.outputs
            .iter()
            .filter(|o| o.is_finding())
            .map(output_summary),
    );
    out
}

fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

fn times(r: &InputResult) -> String {
    let one = |what: &str, s: &super::walk::Seen| {
        format!(
            "{what} {:.3} s (within {})",
            s.t.as_secs_f64(),
            ms(s.window)
        )
    };
    let mut parts = Vec::new();
    if let Some(s) = &r.triggered {
        parts.push(one("active", s));
    }
    if let Some(s) = &r.released {
        parts.push(one("back", s));
    }
    parts.join(", ")
}

fn level_cell(r: &InputResult) -> String {
    r.active_level.map_or("-".to_owned(), |l| {
        format!("{} ({})", u8::from(l), level_word(&r.channel, l))
    })
}

fn input_row(n: usize, r: &InputResult) -> String {
    let mut note = Vec::new();
    if !r.others.is_empty() {
        note.push(format!("moved instead: {}", labelled(&r.others)));
    }
    if r.chattered {
        note.push("chatters".to_owned());
    }
    format!(
        "| {n} | {} | {} | {} | {} | {} | {} | {} |",
        cell(&r.channel.label()),
        r.channel.address,
        r.verdict.word(),
        level_cell(r),
        u8::from(r.channel.active),
        times(r),
        cell(&note.join("; "))
    )
}

/// The report as Markdown.
pub fn markdown(meta: &Meta, walk: &WalkTest) -> String {
    let mut md = String::new();
    md.push_str("# Commissioning report\n\n");
    md.push_str(&format!(
        "- Machine: {} ({})\n- Profile: {}\n- Controller: {} on {}, {} baud\n- Date: {}\n",
        meta.machine,
        meta.description,
        meta.profile,
        meta.protocol,
        meta.port,
        meta.baud,
        meta.date
    ));
    if let Some(every) = meta.read_every {
        md.push_str(&format!(
            "- Inputs read every {} at most: a pulse shorter than that may have been missed\n",
            ms(every)
        ));
    }
    if walk.ended_early {
        md.push_str("- Ended early: the steps not done are listed as skipped\n");
    }
    md.push_str("- No axis was moved\n");
    let findings = findings(walk);
    md.push_str("\n## Findings\n\n");
    let all: Vec<&InputResult> = walk
        .estop()
        .map(|e| e.circuits.iter())
        .into_iter()
        .flatten()
        .chain(walk.inputs.iter())
        .collect();
    let skipped = all
        .iter()
        .filter(|r| r.verdict == super::walk::Verdict::Skipped)
        .count();
    if findings.is_empty() {
        md.push_str("None among the inputs walked: each toggled at its expected level.\n");
    } else {
        for f in &findings {
            md.push_str(&format!("- {f}\n"));
        }
    }
    if skipped > 0 {
        md.push_str(&format!(
            "\n{skipped} of {} inputs were skipped: not checked.\n",
            all.len()
        ));
    }
    let header = "| # | input | address | result | active level | the profile's | times (t since the link came up) | notes |\n|---|---|---|---|---|---|---|---|\n";
    if let Some(e) = walk.estop() {
        md.push_str("\n## E-stop circuits\n\n");
        md.push_str(header);
        for (i, r) in e.circuits.iter().enumerate() {
            md.push_str(&input_row(i + 1, r));
            md.push('\n');
        }
        md.push('\n');
        match e.open_skew {
            Some((m, lo, hi)) => md.push_str(&format!(
                "Opening skew: {} (between {} and {}).\n",
                ms(m),
                ms(lo),
                ms(hi)
            )),
            None => md.push_str("Opening skew: not measured (the circuits did not both open).\n"),
        }
        if let Some(c) = e.close_skew {
            md.push_str(&format!("Closing skew: {}.\n", ms(c)));
        }
    }
    md.push_str("\n## Inputs\n\n");
    md.push_str(header);
    for (i, r) in walk.inputs.iter().enumerate() {
        md.push_str(&input_row(i + 1, r));
        md.push('\n');
    }
    if !walk.outputs.is_empty() {
        md.push_str("\n## Outputs\n\n| output | address | result | inputs that followed |\n|---|---|---|---|\n");
        for o in &walk.outputs {
            let result = o.outcome();
            md.push_str(&format!(
                "| {} | {} | {} | {} |\n",
                cell(&o.name),
                output_address(o.output),
                cell(&result),
                cell(&labelled(&o.inputs_followed))
            ));
        }
    }
    md
}
