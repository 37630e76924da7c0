//! Linear variable bandpass filter (LVF): wavelength calibration from mercury-lamp photos
//! (Nalbach et al. 2017, §4.2 and Fig. 5).
//!
//! Seen through an LVF, each lamp line *l* of wavelength λ_l appears as a blob along the filter
//! axis: at position *x* the filter passes wavelengths around λ(*x*) with a passband shape
//! *g*, so camera channel *c* records
//!
//! ```text
//! y_c(x) = b_c + s_c·u(x) + Σ_l A_{l,c} · g(λ_l − λ(x); FWHM),      u = (x − x_mid)/half_length
//! ```
//!
//! (the line's power times the camera's sensitivity at λ_l is one amplitude A_{l,c} ≥ 0 per line
//! and channel). With a ~25 nm passband neighbouring mercury lines (404.7/407.8/435.8 and
//! 546.1/577.0/579.1 nm) merge into blobs whose peaks are pulled towards each other, so picking
//! peaks ([`peaks::calibrate_peaks`], the paper's procedure, kept as a baseline) biases the map.
//! [`fit::calibrate_whole_profile`] fits the whole profile instead: the map λ(x) (linear, or
//! quadratic when the data justify it) and the FWHM are nonlinear parameters, the amplitudes and
//! background are linear and solved by non-negative least squares for every trial of the
//! nonlinear ones (variable projection, Golub & Pereyra 1973), and the start comes from a coarse
//! grid search. Uncertainties come from the Jacobian of the projected residual.
//!
//! Units: positions in the input image's pixels (0 = first column/row, pixel centres at
//! integers), wavelengths in nm. No colour-science counterpart.

pub mod background;
pub mod calibration;
pub mod capture_synth;
pub mod censored;
pub mod extra_lines;
pub mod fit;
pub mod flat;
pub mod flat_synth;
pub mod geometry;
pub mod lamp;
pub mod line_colour;
pub mod misfit;
pub mod noise;
pub mod passband_continuum;
pub mod peaks;
pub mod profile;
pub mod shared_continuum;
pub mod sigma;
pub mod synth;
pub mod transmission;
pub(crate) mod unlisted;

pub use background::{BackgroundChoice, BackgroundTerms};
pub use calibration::{Band, LineReport, LvfCalibration, MapKind, MapModel};
pub use fit::{
    calibrate_whole_profile, FitOptions, MapChoice, Passband, CONTINUUM_SIGMA_HINT_NM,
    SPLIT_PRIOR_TAU,
};
pub use geometry::{BandReadings, LvfGeometry};
pub use lamp::{Lamp, LampLine};
pub use peaks::calibrate_peaks;
pub use profile::{
    estimate_tilt, extract_profile, extract_profile_straightened, extract_profile_tilted,
    prepare_profile, repair_known_patches, repair_occlusions, Axis, Occlusion, PreparedProfile,
    Profile, Tilt, TiltChoice, TiltEstimate,
};
pub use shared_continuum::CameraResponse;
pub use synth::{render_lvf, LvfSynthSpec, LvfTruth};
