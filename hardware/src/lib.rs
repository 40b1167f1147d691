//! # vistaf-hardware
//!
//! Everything that touches hardware, behind traits: the camera (`FrameSource`), the LED
//! ring (`LedRing`), frame-set replay and recording, and the simulated skin that stands in
//! for all of them in tests and demos.
