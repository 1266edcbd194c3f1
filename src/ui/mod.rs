//! The terminal UI, in The Elm Architecture (`docs/ui.md`):
//!
//! - [`model::Model`]: all UI state; [`msg::Msg`] in, [`msg::Effect`] out.
//! - [`update::update`]: the only code that changes the model. Keys become
//!   actions through the [`keymap`] (data: mode -> key -> action), safety
//!   keys before any focus or popup routing.
//! - [`view::Screen`]: drawing, a pure function of the model.
//!
//! The state behind the panels lives in small modules of its own
//! ([`position`], [`io`], [`traffic_log`], [`line_edit`], [`sim_panel`],
//! [`jog`] for the jog keypad, the program [`editor`] and the port
//! [`timeline`] with screens of their own);
//! [`raw`] checks typed commands with each family's parser; [`typing`]
//! decides where typed and pasted text goes, what keys that arrive together
//! may do, and when Space types rather than stops.
//!
//! Around it: [`terminal`] owns the terminal (restored on drop, error and
//! panic), [`input`] reads keys on its own thread, [`runtime`] runs the loop
//! that feeds `update` and carries out its effects.

pub mod console;
pub mod editor;
pub mod frame;
pub mod help;
pub mod input;
pub mod io;
pub mod jog;
pub mod key;
pub mod keymap;
pub mod legs;
pub mod line_edit;
pub mod macros;
pub mod messages;
pub mod model;
pub mod msg;
pub mod outcome;
pub mod palette;
pub mod popups;
pub mod position;
pub mod probe;
pub mod raw;
pub mod runtime;
pub mod setup;
pub mod sim_panel;
pub mod summary;
pub mod terminal;
pub mod timeline;
pub mod tools;
pub mod traffic_log;
pub mod typing;
pub mod update;
pub mod view;

pub use model::{Model, Setup};
pub use msg::{Effect, Msg};
pub use update::update;
pub use view::Screen;
