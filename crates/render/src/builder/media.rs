//! Media: pbrt-v4's `MakeNamedMedium` directive (`homogeneous`, absorbing only) and the medium names that
//! `MediumInterface` and the camera's medium refer to.

use std::collections::HashMap;

use scene::{Loc, SceneDescription, SceneError, SpectrumKind};
use spectral::Spectrum;

use super::{err, unsupported, Result};
use crate::scene::AbsorbingMedium;

/// The scene's media and the index each name maps to.
pub(super) struct Media {
    /// In the order of [`crate::scene::RenderScene::media`].
    pub(super) list: Vec<AbsorbingMedium>,
    index: HashMap<String, u32>,
}

impl Media {
    /// Reads every named medium (absorbing homogeneous only).
    pub(super) fn build(desc: &SceneDescription) -> Result<Self> {
        let mut media = vec![];
        let mut medium_index: HashMap<String, u32> = HashMap::new();
        for m in &desc.media {
            let p = &m.entity.params;
            if m.entity.name != "homogeneous" {
                return err(&m.entity.loc, unsupported("medium", &m.entity.name, &["homogeneous (absorbing)"]));
            }
            let sigma_s = p.get_spectrum("sigma_s", SpectrumKind::Unbounded)?;
            if sigma_s.as_ref().is_some_and(|s| s.max_value() > 0.0) {
                return err(&m.entity.loc, "scattering media ('sigma_s' > 0) are not supported yet: only absorption");
            }
            let scale = p.get_float("scale", 1.0)?;
            let sigma_a =
                p.get_spectrum("sigma_a", SpectrumKind::Unbounded)?.unwrap_or(Spectrum::Constant(1.0)).scaled(scale);
            medium_index.insert(m.medium_name.clone(), media.len() as u32);
            media.push(AbsorbingMedium { sigma_a });
        }
        Ok(Media { list: media, index: medium_index })
    }

    /// The medium `name` refers to; no name or an empty one is vacuum.
    pub(super) fn of(&self, name: &Option<String>, loc: &Loc) -> Result<Option<u32>> {
        match name {
            None => Ok(None),
            Some(n) if n.is_empty() => Ok(None),
            Some(n) => self
                .index
                .get(n)
                .copied()
                .map(Some)
                .ok_or_else(|| SceneError::at(loc.clone(), format!("no medium named '{n}'"))),
        }
    }
}
