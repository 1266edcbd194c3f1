//! Lines of standard input read on a thread of their own, for the
//! commands that take answers from a pipe (`commission`, `run`'s waits):
//! a blocking read never holds up the session's loop.

/// Lines typed on stdin, read on a thread of their own; `None` once it has
/// closed.
pub fn stdin_lines() -> tokio::sync::mpsc::UnboundedReceiver<Option<String>> {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let _ = std::thread::Builder::new()
        .name("jogterm-stdin".into())
        .spawn(move || {
            let stdin = std::io::stdin();
            let mut line = String::new();
            loop {
                line.clear();
                match stdin.read_line(&mut line) {
                    Ok(0) | Err(_) => {
                        let _ = tx.send(None);
                        return;
                    }
                    Ok(_) => {
                        if tx.send(Some(line.clone())).is_err() {
                            return;
                        }
                    }
                }
            }
        });
    rx
}
