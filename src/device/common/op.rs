//! The skeleton of every driver's operations: one runs at a time, says
//! what it wants sent next ([`Next`]), and may end early ([`Abandon`]);
//! the driver keeps it in an enum of its family's operations, which
//! `operations!` declares together with the way to reach the one that
//! runs as the family's `Operation` trait object, whose messages it
//! sends ([`Owner`]), and its timer and activity for the driver core
//! (`core::Running`).

/// Why an operation ends early.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Abandon {
    LinkLost(String),
    /// The controller dropped everything (isel 0xFE, manual 2.2.31; EMCU
    /// `@R` or `@S`, manual 1.5.1, 1.5.12).
    Reset,
}

impl Abandon {
    /// Why, in words; `device` names what was reset (`controller`,
    /// `interface`).
    pub fn reason(&self, device: &str) -> String {
        match self {
            Abandon::LinkLost(r) => format!("link lost: {r}"),
            Abandon::Reset => format!("the {device} was reset"),
        }
    }
}

/// What an operation wants next: a command (`C`, the family's) to send,
/// nothing now (a timer, or a run under way: polls may go meanwhile), or
/// nothing more.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Next<C> {
    Send(C),
    Wait,
    Done,
}

/// Declares a driver's enum of operations, each variant holding one that
/// implements the family's `Operation` trait (`Motion(Box<MotionOp> as
/// MotionOp)` for a boxed one), and its methods:
/// - `get` / `peek`: the operation as `&mut dyn Operation` / `&dyn Operation`;
/// - `owner`: whose the messages it sends are (`traffic::Owner`), as given
///   per variant after `=>`.
macro_rules! operations {
    (@inner $field:ty) => { $field };
    (@inner $field:ty, $inner:ty) => { $inner };
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident: $op:path {
            $(
                $(#[$vmeta:meta])*
                $variant:ident($field:ty $(as $inner:ty)?) => $owner:ident
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis enum $name {
            $($(#[$vmeta])* $variant($field)),*
        }

        impl $name {
            #[allow(dead_code)]
            $vis fn get(&mut self) -> &mut dyn $op {
                match self {
                    $($name::$variant(o) => {
                        let o: &mut $crate::device::common::op::operations!(@inner $field $(, $inner)?) = o;
                        o
                    })*
                }
            }

            #[allow(dead_code)]
            $vis fn peek(&self) -> &dyn $op {
                match self {
                    $($name::$variant(o) => {
                        let o: &$crate::device::common::op::operations!(@inner $field $(, $inner)?) = o;
                        o
                    })*
                }
            }

            /// Whose the messages this operation sends are.
            #[allow(dead_code)]
            $vis fn owner(&self) -> $crate::traffic::Owner {
                match self {
                    $($name::$variant(_) => $crate::traffic::Owner::$owner),*
                }
            }
        }

        impl $crate::device::common::core::Running for $name {
            fn timer(&self) -> Option<std::time::Instant> {
                self.peek().timer()
            }

            fn activity(&self) -> $crate::device::api::Activity {
                self.peek().activity()
            }
        }
    };
}

pub(crate) use operations;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traffic::Owner;

    trait Speak {
        fn word(&self) -> &'static str;
        fn set(&mut self, _word: &'static str) {}
        fn timer(&self) -> Option<std::time::Instant> {
            None
        }
        fn activity(&self) -> crate::device::api::Activity {
            crate::device::api::Activity::Idle
        }
    }

    #[derive(Debug, Default)]
    struct Small(&'static str);

    impl Speak for Small {
        fn word(&self) -> &'static str {
            self.0
        }
        fn set(&mut self, word: &'static str) {
            self.0 = word;
        }
    }

    #[derive(Debug, Default)]
    struct Large(u64);

    impl Speak for Large {
        fn word(&self) -> &'static str {
            if self.0 == 0 { "large" } else { "larger" }
        }
    }

    operations! {
        #[derive(Debug)]
        enum Op: Speak {
            Small(Small) => Poll,
            Large(Box<Large> as Large) => Motion,
        }
    }

    #[test]
    fn every_variant_is_reached_boxed_or_not() {
        let mut small = Op::Small(Small("small"));
        small.get().set("changed");
        assert_eq!(small.peek().word(), "changed");
        assert_eq!(small.owner(), Owner::Poll);
        let large = Op::Large(Box::default());
        assert_eq!(large.peek().word(), "large");
        assert_eq!(large.owner(), Owner::Motion);
    }

    #[test]
    fn a_reset_is_named_for_the_family() {
        assert_eq!(
            Abandon::Reset.reason("interface"),
            "the interface was reset"
        );
        assert_eq!(
            Abandon::LinkLost("gone".into()).reason("controller"),
            "link lost: gone"
        );
    }
}
