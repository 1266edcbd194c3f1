//! What the controller received (`show received`, in `traffic::readable`
//! form) split into messages (isel, EMCU, EMP), and the motion commands
//! among them: the suite's proof that no motion command went out twice.

/// isel: commands end at CR (returned without it); the control bytes 0xFD,
/// 0xFE, 0xFF are messages of their own, also between two bytes of a command
/// (the controller reads them in its receive interrupt, isel manual 2.2.31).
pub fn isel_messages(readable: &str) -> Vec<String> {
    split_messages(readable, &["<CR>"], &["<FD>", "<FE>", "<FF>"])
}

/// Splits readable traffic into messages: each token in `ends` closes the
/// message gathered so far (returned without it), each token in `own` is a
/// message of its own without closing the one it interrupts; `<3C>` is the
/// readable form of a literal `<`.
fn split_messages(readable: &str, ends: &[&str], own: &[&str]) -> Vec<String> {
    let mut messages = Vec::new();
    let mut message = String::new();
    let mut rest = readable;
    while let Some(c) = rest.chars().next() {
        if c == '<'
            && let Some(end) = rest.find('>')
        {
            let token = &rest[..=end];
            rest = &rest[end + 1..];
            if ends.contains(&token) {
                messages.push(std::mem::take(&mut message));
            } else if own.contains(&token) {
                messages.push(token.to_string());
            } else if token == "<3C>" {
                message.push('<');
            } else {
                message.push_str(token);
            }
            continue;
        }
        message.push(c);
        rest = &rest[c.len_utf8()..];
    }
    messages
}

/// An isel command that makes an axis travel: absolute and relative moves
/// (a relative move of zero steps everywhere is jogterm's reference probe,
/// which moves nothing), reference runs, program starts.
pub fn isel_moves(command: &str) -> bool {
    let Some(rest) = command.strip_prefix("@0") else {
        return false;
    };
    match rest.chars().next() {
        Some('M' | 'm' | 'R' | 'S') => true,
        Some('A') => rest[1..]
            .split(',')
            .step_by(2)
            .any(|steps| steps.trim().trim_start_matches('+').trim_start_matches('-') != "0"),
        _ => false,
    }
}

/// The isel motion commands received, in order.
pub fn isel_motion(readable: &str) -> Vec<String> {
    isel_messages(readable)
        .into_iter()
        .filter(|m| isel_moves(m))
        .collect()
}

/// EMCU: lines end at CR or 0x01 (manual 1.4.2); the lines that can move
/// an axis (`Command::may_move`: moves, reference runs, resume, run job).
pub fn emcu_motion(readable: &str) -> Vec<String> {
    split_messages(readable, &["<CR>", "<01>"], &[])
        .into_iter()
        .filter(|l| jogterm::proto::emcu::parse_line(l).is_ok_and(|c| c.may_move()))
        .collect()
}

/// EMP: frames end at EOF 0x1A (`<EOF>` in readable form; EMP manual "Easy
/// Motion Protocol": every string ends with EOF), returned without it.
pub fn emp_frames(readable: &str) -> Vec<String> {
    let mut frames: Vec<String> = readable
        .split("<EOF>")
        .map(|f| f.replace("<3C>", "<"))
        .collect();
    // What follows the last EOF is a frame not yet complete.
    frames.pop();
    frames
}

/// The EMP frames that can make an axis travel (`Command::may_move`:
/// positioning, velocity and torque moves, homing, joystick on).
pub fn emp_motion(readable: &str) -> Vec<String> {
    emp_frames(readable)
        .into_iter()
        .filter(|f| {
            f.parse::<jogterm::proto::emp::Request>()
                .is_ok_and(|r| r.command.may_move())
        })
        .collect()
}

/// The EMP frames received after the last `frame` (none if it never came).
pub fn emp_after(readable: &str, frame: &str) -> Vec<String> {
    let frames = emp_frames(readable);
    match frames.iter().rposition(|f| f == frame) {
        Some(i) => frames.into_iter().skip(i + 1).collect(),
        None => Vec::new(),
    }
}

/// The parser's own checks, run by the suite before the scenarios.
pub fn self_check() {
    assert_eq!(
        isel_messages("<FD><FF>@0P<CR>@0M1<FD><FF>0,900<CR>a<3C>b<CR>"),
        ["<FD>", "<FF>", "@0P", "<FD>", "<FF>", "@0M10,900", "a<b"]
    );
    assert!(isel_moves("@0M100,900,0,900,0,900,0,900"));
    assert!(isel_moves("@0A100,900,0,900,0,900,0,900"));
    assert!(!isel_moves("@0A0,900,0,900,0,900,0,900"));
    assert!(!isel_moves("@0P"));
    assert!(isel_moves("@0R7"));
    assert!(!isel_moves("<FD>"));
    assert_eq!(emcu_motion("@X<CR>@LX<CR>L1,x100<01>@X<CR>"), ["L1,x100"]);
    let emp = "2C11000000000000<EOF>2A11016400124F80<EOF>0811000000000000<EOF>\
               2A11000000000000<EOF>2611000000140400<EOF>2C1100";
    assert_eq!(
        emp_frames(emp),
        [
            "2C11000000000000",
            "2A11016400124F80",
            "0811000000000000",
            "2A11000000000000",
            "2611000000140400"
        ]
    );
    // A velocity move at 0 and a stop move nothing.
    assert_eq!(emp_motion(emp), ["2A11016400124F80", "2611000000140400"]);
    assert_eq!(
        emp_after(emp, "2A11016400124F80")
            .first()
            .map(String::as_str),
        Some("0811000000000000")
    );
}

#[test]
fn the_split_reads_its_own_examples() {
    self_check();
}
