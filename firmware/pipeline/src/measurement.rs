//! What the pipeline reports for one frame: the depth map and its features (contact,
//! area, volume, centre, force), the temperatures, and the flags that say what may be wrong.

use vistaf_protocol::QualityFlags;

use crate::calibration::ForceInputs;
use crate::measure::profile::Shape;
use crate::thermal::Temperature;

/// The result of analysing one frame.
#[derive(Clone, PartialEq)]
pub struct Measurement {
    /// Working width, pixels.
    pub width_px: usize,
    /// Working height, pixels.
    pub height_px: usize,
    /// Input pixels per working pixel (each axis).
    pub factor: usize,
    /// Depth per working pixel, µm (0 where there is no deformation).
    pub depth_um: Vec<i32>,
    /// Whether each working pixel's phase was trusted.
    pub reliable: Vec<bool>,
    /// Whether any contact was found.
    pub contact: bool,
    /// Deepest point, mm, with the demodulator's blur taken out (`crate::measure::apex`).
    pub peak_depth_mm: f32,
    /// The depth map's value at the contact's apex, µm (the blurred peak; 0 without contact).
    pub map_peak_um: i32,
    /// Contact area (depth ≥ half the peak: the Hertz contact radius for a sphere), mm².
    pub contact_area_mm2: f32,
    /// Measurement volume over pixels deeper than the noise floor, mm³.
    pub volume_mm3: f32,
    /// Contact centre in input-image pixels (depth-weighted over the contact area).
    pub centroid_px: Option<(f32, f32)>,
    /// Reciprocal load (the force over the skin's modulus, `crate::measure::load`), mm².
    pub reciprocal_load_mm2: f32,
    /// Indentation phase integrated over the deformed area, rad·mm².
    pub integrated_phase_rad_mm2: f32,
    /// Normal force from the calibration's force model, N.
    pub force_n: f32,
    /// The contact's shape as its profile shows it (`crate::measure::profile`): a flat
    /// punch's depth is its plateau's.
    pub shape: Shape,
    /// What may be wrong.
    pub flags: QualityFlags,
    /// Measured phase noise floor (1σ), rad.
    pub noise_rad: f32,
    /// Global phase offset removed (registration), rad.
    pub offset_rad: f32,
    /// Depth of the contact threshold (6 σ of phase noise): the map reports depth above it, µm.
    pub floor_um: i32,
    /// Contact tiles processed.
    pub tiles: usize,
    /// The contact window `[x0, y0, x1, y1)`, working pixels: `depth_um` is zero outside it.
    pub window_px: Option<[usize; 4]>,
    /// Temperatures, when the calibration has a colour → temperature model.
    pub temperature: Option<Temperature>,
}

impl Measurement {
    /// What the force model reads of this frame's contact.
    pub fn force_inputs(&self) -> ForceInputs {
        ForceInputs {
            area_mm2: self.contact_area_mm2,
            peak_mm: self.peak_depth_mm,
            volume_mm3: self.volume_mm3,
            integrated_phase_rad_mm2: self.integrated_phase_rad_mm2,
            reciprocal_load_mm2: self.reciprocal_load_mm2,
        }
    }
}

impl std::fmt::Debug for Measurement {
    /// The summary numbers; the maps only by size.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Measurement")
            .field(
                "map",
                &format_args!("{}×{} (÷{})", self.width_px, self.height_px, self.factor),
            )
            .field("contact", &self.contact)
            .field("peak_depth_mm", &self.peak_depth_mm)
            .field("contact_area_mm2", &self.contact_area_mm2)
            .field("volume_mm3", &self.volume_mm3)
            .field("centroid_px", &self.centroid_px)
            .field("reciprocal_load_mm2", &self.reciprocal_load_mm2)
            .field("force_n", &self.force_n)
            .field("shape", &self.shape)
            .field(
                "flags",
                &self.flags.iter().map(|f| f.name()).collect::<Vec<_>>(),
            )
            .field("noise_rad", &self.noise_rad)
            .field("offset_rad", &self.offset_rad)
            .field("floor_um", &self.floor_um)
            .field("tiles", &self.tiles)
            .field(
                "temperature_c",
                &self
                    .temperature
                    .as_ref()
                    .map(|t| (t.min_c, t.mean_c, t.max_c, t.contact_c)),
            )
            .finish()
    }
}
