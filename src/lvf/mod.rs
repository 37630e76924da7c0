//! Linear variable bandpass filter (LVF): wavelength calibration from mercury-lamp photos (Nalbach et al. 2017, §4.2).
