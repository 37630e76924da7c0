//! Charts for `phos simulate` (emission under an irradiance history) and `phos design`
//! (keyframe targets against the designed material).
