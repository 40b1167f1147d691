//! The LED ring: WS2812 ("NeoPixel") LEDs driven from the SPI bus.
//!
//! WS2812 LEDs read one wire at 800 kHz: a bit is a high pulse followed by a low one, short
//! high (0.40 µs) for 0 and long high (0.80 µs) for 1, each bit 1.25 µs ±600 ns; a low line
//! for more than 50 µs latches the colours. The SPI bus clocked near 3.2 MHz produces these
//! pulses with 4 SPI bits per LED bit (`1000` = 0, `1110` = 1; 312.5 ns per SPI bit); the
//! encoding is done by `ws2812-spi`'s hosted driver, which sends the whole ring in one
//! transfer framed by runs of zero bytes (the reset/latch gap). Colour order on the wire is
//! green, red, blue; most significant bit first.
//!
//! Colours are gamma-corrected (the LEDs are linear; our eyes and camera are not) and then
//! scaled by the global brightness, as the reference build's Adafruit firmware does.
//!
//! The ring goes dark on drop, so a crash or SIGTERM never leaves it lit.
//!
//! Wiring on a Raspberry Pi: data on SPI0 MOSI (GPIO 10, pin 19), through a 3.3 → 5 V level
//! shifter (74AHCT125), ring powered from 5 V with a 1000 µF capacitor across it. Enable
//! SPI with `dtparam=spi=on` in `/boot/firmware/config.txt`.

use embedded_hal::spi::SpiBus;
use smart_leds::{brightness, gamma, SmartLedsWrite, RGB8};
use ws2812_spi::hosted::Ws2812;

/// SPI clock for WS2812 encoding, Hz (4 SPI bits = 1.25 µs LED bit).
pub const SPI_CLOCK_HZ: u32 = 3_200_000;

/// Number of LEDs on the reference ring.
pub const DEFAULT_LED_COUNT: usize = 24;

/// Colour of the lit LEDs on the reference build.
pub const DEFAULT_RGB: RGB8 = RGB8 {
    r: 210,
    g: 245,
    b: 125,
};

/// Global brightness of the reference build, of 255.
pub const DEFAULT_BRIGHTNESS: u8 = 30;

/// Lit-LED mask of the reference build: the 12 odd-indexed LEDs of 24.
pub const DEFAULT_LIT_MASK: u32 = 0x00AA_AAAA;

/// What the ring should show.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LedConfig {
    /// LEDs on the ring (≤ 32).
    pub count: usize,
    /// Colour of the lit LEDs.
    pub rgb: RGB8,
    /// Global brightness, 0–255.
    pub brightness: u8,
    /// Bit i lights LED i.
    pub lit_mask: u32,
}

impl Default for LedConfig {
    fn default() -> Self {
        LedConfig {
            count: DEFAULT_LED_COUNT,
            rgb: DEFAULT_RGB,
            brightness: DEFAULT_BRIGHTNESS,
            lit_mask: DEFAULT_LIT_MASK,
        }
    }
}

impl LedConfig {
    /// The colour of each LED, before gamma and brightness.
    pub fn colors(&self) -> Vec<RGB8> {
        (0..self.count)
            .map(|i| {
                if i < 32 && self.lit_mask >> i & 1 == 1 {
                    self.rgb
                } else {
                    RGB8::default()
                }
            })
            .collect()
    }
}

/// An LED ring error.
#[derive(Debug, thiserror::Error)]
pub enum LedError {
    /// The SPI transfer failed.
    #[error("LED ring: SPI write failed: {0}")]
    Spi(String),
    /// The SPI bus could not be opened.
    #[error("LED ring: cannot open {bus}: {detail}")]
    Open {
        /// The bus.
        bus: String,
        /// Why.
        detail: String,
    },
    /// More LEDs than the mask can address.
    #[error("LED ring: {0} LEDs configured, at most 32 supported")]
    TooMany(usize),
}

/// The LED ring seam.
pub trait LedRing: Send {
    /// Shows `config`.
    fn show(&mut self, config: &LedConfig) -> Result<(), LedError>;
    /// Turns every LED off.
    fn off(&mut self) -> Result<(), LedError>;
}

/// A WS2812 ring on any embedded-hal SPI bus.
pub struct SpiLedRing<S: SpiBus<u8>> {
    driver: Ws2812<S>,
    count: usize,
}

impl<S: SpiBus<u8>> std::fmt::Debug for SpiLedRing<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpiLedRing")
            .field("count", &self.count)
            .finish_non_exhaustive()
    }
}

impl<S: SpiBus<u8>> SpiLedRing<S> {
    /// A ring of `count` LEDs on `spi` (clocked at [`SPI_CLOCK_HZ`] by its owner).
    pub fn new(spi: S, count: usize) -> SpiLedRing<S> {
        SpiLedRing {
            driver: Ws2812::new(spi),
            count,
        }
    }

    fn write(&mut self, colors: Vec<RGB8>, level: u8) -> Result<(), LedError> {
        self.driver
            .write(brightness(gamma(colors.into_iter()), level))
            .map_err(|e| LedError::Spi(format!("{e:?}")))
    }
}

impl<S: SpiBus<u8> + Send> LedRing for SpiLedRing<S> {
    fn show(&mut self, config: &LedConfig) -> Result<(), LedError> {
        if config.count > 32 {
            return Err(LedError::TooMany(config.count));
        }
        self.count = config.count;
        self.write(config.colors(), config.brightness)
    }

    fn off(&mut self) -> Result<(), LedError> {
        self.write(vec![RGB8::default(); self.count], 0)
    }
}

impl<S: SpiBus<u8>> Drop for SpiLedRing<S> {
    fn drop(&mut self) {
        let dark = vec![RGB8::default(); self.count];
        let _ = self.driver.write(dark);
    }
}

/// A ring that only remembers what it was told (tests, simulation, boards without LEDs).
#[derive(Debug, Default, Clone)]
pub struct MemoryLedRing {
    /// Every configuration shown, in order; `None` for "off".
    pub log: Vec<Option<LedConfig>>,
}

impl MemoryLedRing {
    /// Whether the ring is currently lit.
    pub fn is_lit(&self) -> bool {
        matches!(self.log.last(), Some(Some(c)) if c.brightness > 0 && c.lit_mask != 0)
    }
}

impl LedRing for MemoryLedRing {
    fn show(&mut self, config: &LedConfig) -> Result<(), LedError> {
        if config.count > 32 {
            return Err(LedError::TooMany(config.count));
        }
        self.log.push(Some(*config));
        Ok(())
    }

    fn off(&mut self) -> Result<(), LedError> {
        self.log.push(None);
        Ok(())
    }
}

/// Opens the ring on the Raspberry Pi's SPI0 (CE0), clocked for WS2812.
#[cfg(feature = "rpi")]
pub fn open_pi_ring(count: usize) -> Result<SpiLedRing<rppal::spi::Spi>, LedError> {
    use rppal::spi::{Bus, Mode, SlaveSelect, Spi};
    let spi = Spi::new(Bus::Spi0, SlaveSelect::Ss0, SPI_CLOCK_HZ, Mode::Mode0).map_err(|e| {
        LedError::Open {
            bus: "/dev/spidev0.0".into(),
            detail: format!(
                "{e} (is SPI enabled with dtparam=spi=on, and is the user in group spi?)"
            ),
        }
    })?;
    Ok(SpiLedRing::new(spi, count))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// An SPI bus that records every byte written.
    #[derive(Clone, Default)]
    struct RecordingSpi(Arc<Mutex<Vec<Vec<u8>>>>);

    impl embedded_hal::spi::ErrorType for RecordingSpi {
        type Error = std::convert::Infallible;
    }

    impl SpiBus<u8> for RecordingSpi {
        fn read(&mut self, words: &mut [u8]) -> Result<(), Self::Error> {
            words.fill(0);
            Ok(())
        }
        fn write(&mut self, words: &[u8]) -> Result<(), Self::Error> {
            self.0.lock().unwrap().push(words.to_vec());
            Ok(())
        }
        fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), Self::Error> {
            read.fill(0);
            self.write(write)
        }
        fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), Self::Error> {
            let w = words.to_vec();
            self.write(&w)
        }
        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    /// Decodes the SPI byte stream back into LED bits, checking each 4-bit symbol.
    fn decode(stream: &[u8]) -> (usize, Vec<[u8; 3]>, usize) {
        let lead = stream.iter().take_while(|&&b| b == 0).count();
        let trail = stream.iter().rev().take_while(|&&b| b == 0).count();
        let body = &stream[lead..stream.len() - trail];
        let mut bits = Vec::new();
        for byte in body {
            for nib in [byte >> 4, byte & 0xf] {
                match nib {
                    0b1000 => bits.push(0u8),
                    0b1110 => bits.push(1u8),
                    other => panic!("{other:04b} is not a WS2812 symbol"),
                }
            }
        }
        assert_eq!(bits.len() % 24, 0);
        let leds = bits
            .chunks(24)
            .map(|c| {
                let byte = |k: usize| c[k * 8..k * 8 + 8].iter().fold(0u8, |a, b| a << 1 | b);
                [byte(0), byte(1), byte(2)]
            })
            .collect();
        (lead, leds, trail)
    }

    fn shown(config: &LedConfig) -> (usize, Vec<[u8; 3]>, usize) {
        let spi = RecordingSpi::default();
        let mut ring = SpiLedRing::new(spi.clone(), config.count);
        ring.show(config).unwrap();
        let writes = spi.0.lock().unwrap().clone();
        assert_eq!(writes.len(), 1, "one transfer per update");
        decode(&writes[0])
    }

    #[test]
    fn symbols_give_ws2812_pulse_widths() {
        // At SPI_CLOCK_HZ one SPI bit lasts 312.5 ns: 1000 → 0.31 µs high, 1110 → 0.94 µs
        // high, 1.25 µs per LED bit; all within the datasheet's ±150/±600 ns.
        let bit_ns = 1e9 / f64::from(SPI_CLOCK_HZ);
        assert!((bit_ns * 4.0 - 1250.0).abs() < 1.0);
        assert!((bit_ns - 400.0).abs() <= 150.0, "T0H");
        assert!((bit_ns * 3.0 - 800.0).abs() <= 150.0, "T1H");
    }

    #[test]
    fn reference_build_lights_odd_leds_in_grb_with_gamma_and_brightness() {
        let cfg = LedConfig::default();
        let (lead, leds, trail) = shown(&cfg);
        assert_eq!(leds.len(), 24);
        // Reset gap: ≥ 50 µs of low line at 3.2 MHz = 20 zero bytes; both ends.
        assert!(
            lead * 8 * 3125 / 10 >= 50_000 && trail * 8 * 3125 / 10 >= 50_000,
            "{lead} {trail}"
        );
        let expect = |c: u8| {
            let g = smart_leds::gamma([RGB8 { r: c, g: 0, b: 0 }].into_iter())
                .next()
                .unwrap()
                .r;
            (u16::from(g) * (u16::from(DEFAULT_BRIGHTNESS) + 1) / 256) as u8
        };
        for (i, grb) in leds.iter().enumerate() {
            if i % 2 == 1 {
                assert_eq!(
                    *grb,
                    [expect(245), expect(210), expect(125)],
                    "LED {i} in G, R, B order"
                );
                assert!(grb.iter().any(|&c| c > 0));
            } else {
                assert_eq!(*grb, [0, 0, 0], "LED {i} is dark");
            }
        }
    }

    #[test]
    fn full_brightness_white_is_all_ones_and_drop_turns_off() {
        let spi = RecordingSpi::default();
        {
            let mut ring = SpiLedRing::new(spi.clone(), 3);
            let cfg = LedConfig {
                count: 3,
                rgb: RGB8 {
                    r: 255,
                    g: 255,
                    b: 255,
                },
                brightness: 255,
                lit_mask: 0b111,
            };
            ring.show(&cfg).unwrap();
        }
        let writes = spi.0.lock().unwrap().clone();
        assert_eq!(writes.len(), 2, "show, then dark on drop");
        let (_, on, _) = decode(&writes[0]);
        assert!(
            on.iter().all(|l| l[0] >= 254 && l[1] >= 254 && l[2] >= 254),
            "{on:?}"
        );
        let (_, off, _) = decode(&writes[1]);
        assert_eq!(off, vec![[0, 0, 0]; 3]);
    }

    #[test]
    fn too_many_leds_is_refused() {
        let mut ring = SpiLedRing::new(RecordingSpi::default(), 24);
        let cfg = LedConfig {
            count: 40,
            ..LedConfig::default()
        };
        assert!(matches!(ring.show(&cfg), Err(LedError::TooMany(40))));
        let mut mem = MemoryLedRing::default();
        mem.show(&LedConfig::default()).unwrap();
        assert!(mem.is_lit());
        mem.off().unwrap();
        assert!(!mem.is_lit());
    }
}
