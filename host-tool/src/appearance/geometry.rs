//! The glossmeter geometries: rectangular source and receptor apertures (angular sizes in
//! and across the plane of measurement), the primary black-glass standard, and the table
//! of the standards' geometries ([`GLOSS_20`], [`GLOSS_60`], [`GLOSS_85`], [`E430`]).
//!
//! Sources and the status of every number are in `docs/appearance.md`.

/// Refractive index of the primary black-glass gloss standard (ISO 2813, ASTM D523):
/// its exact unpolarised Fresnel reflectance at each geometry is 100 gloss units.
pub const BLACK_GLASS_N: f64 = 1.567;

/// A rectangular angular aperture, degrees: `width` in the plane of measurement,
/// `height` across it, centred `offset` degrees (in the plane, toward larger polar
/// angles for a receptor) from the nominal direction (the source's incidence, or the
/// receptor's mirror direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Full angular width in the plane of measurement, degrees (> 0).
    pub width: f64,
    /// Full angular height perpendicular to it, degrees (> 0).
    pub height: f64,
    /// Offset of its centre from the nominal direction in the plane, degrees.
    pub offset: f64,
}

impl Rect {
    /// An aperture centred on the nominal direction.
    pub const fn centred(width: f64, height: f64) -> Rect {
        Rect {
            width,
            height,
            offset: 0.0,
        }
    }

    /// The same aperture moved `offset` degrees in the plane.
    pub const fn at(self, offset: f64) -> Rect {
        Rect {
            width: self.width,
            height: self.height,
            offset,
        }
    }
}

/// A specular-gloss geometry: incidence angle (degrees from the normal), the source
/// image and the receptor aperture (both as seen from the sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlossGeometry {
    /// Its name as reported ("20", "60", "85").
    pub name: &'static str,
    /// Incidence (and specular receptor) angle, degrees.
    pub incidence: f64,
    /// The source image's angular size.
    pub source: Rect,
    /// The receptor aperture, centred on the specular direction.
    pub receptor: Rect,
}

/// The source image of ISO 2813 / ASTM D523, the same at every angle: 0.75 degrees in
/// the plane of measurement by 2.5 degrees across it.
pub const GLOSS_SOURCE: Rect = Rect::centred(0.75, 2.5);

/// 20 degree gloss (high gloss): receptor 1.80 x 3.6 degrees.
pub const GLOSS_20: GlossGeometry = GlossGeometry {
    name: "20",
    incidence: 20.0,
    source: GLOSS_SOURCE,
    receptor: Rect::centred(1.80, 3.6),
};

/// 60 degree gloss (all gloss levels): receptor 4.4 x 11.7 degrees.
pub const GLOSS_60: GlossGeometry = GlossGeometry {
    name: "60",
    incidence: 60.0,
    source: GLOSS_SOURCE,
    receptor: Rect::centred(4.4, 11.7),
};

/// 85 degree gloss (low gloss, sheen): receptor 4.0 x 6.0 degrees.
pub const GLOSS_85: GlossGeometry = GlossGeometry {
    name: "85",
    incidence: 85.0,
    source: GLOSS_SOURCE,
    receptor: Rect::centred(4.0, 6.0),
};

/// The three geometries of ISO 2813 / ASTM D523, in increasing angle.
pub const GLOSS_GEOMETRIES: [GlossGeometry; 3] = [GLOSS_20, GLOSS_60, GLOSS_85];

/// An abridged-goniophotometer geometry (ASTM E430): a narrow source slit at one
/// incidence, a specular receptor, two receptors a small angle either side of the
/// specular direction (distinctness of image) and two a larger angle either side
/// (reflection haze), all as wide as stated here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct E430Geometry {
    /// Incidence (and specular) angle, degrees.
    pub incidence: f64,
    /// The source slit.
    pub source: Rect,
    /// The specular receptor (offset 0).
    pub specular: Rect,
    /// The distinctness-of-image receptor, offset +-`doi_offset` degrees.
    pub doi: Rect,
    /// Offset of the DOI receptors from the specular direction, degrees.
    pub doi_offset: f64,
    /// The haze receptor, offset +-`haze_offset` degrees.
    pub haze: Rect,
    /// Offset of the haze receptors from the specular direction, degrees.
    pub haze_offset: f64,
}

/// ASTM E430 Test Method A (30 degrees): DOI 0.3 degrees and haze 2 degrees off
/// specular. The aperture widths are this project's choice after the method's
/// description (see `docs/appearance.md`: not checked against the standard's table).
pub const E430: E430Geometry = E430Geometry {
    incidence: 30.0,
    source: Rect::centred(0.1, 1.0),
    specular: Rect::centred(0.14, 1.0),
    doi: Rect::centred(0.14, 1.0),
    doi_offset: 0.3,
    haze: Rect::centred(0.44, 1.0),
    haze_offset: 2.0,
};
