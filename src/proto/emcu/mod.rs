//! EMCU interface on SMC3000 stepper cards: master and buffered commands, CR
//! acknowledgements, the unsolicited ready/memory-full lines.
