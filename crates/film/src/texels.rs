//! Texels as a texture keeps them. An 8-bit image stays 8-bit, each sample decoded through a table of its 256
//! linear values when it is read: that is the value decoding it up front would give, in a quarter of the memory.
//! An image whose three colours are equal everywhere (a grey image, or one channel picked out of a colour image,
//! such as glTF's metalness or roughness) keeps one value per texel: a third of the memory again. Images of more
//! than 8 bits keep linear floats.

use std::sync::Arc;

/// A table of the linear values of the 256 8-bit samples.
pub type SampleTable = Arc<[f32; 256]>;

/// The 256 linear values `to_linear` gives the 8-bit samples 0 to 255 (its argument the sample over 255).
pub fn sample_table(to_linear: impl Fn(f64) -> f64) -> SampleTable {
    Arc::new(std::array::from_fn(|v| to_linear(v as f64 / 255.0) as f32))
}

/// An image's texels (rows from the top, each left to right), read as linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    /// Linear RGB.
    Rgb(Vec<[f32; 3]>),
    /// One linear value per texel, standing for red, green and blue.
    Grey(Vec<f32>),
    /// 8-bit RGB samples, each read through `table`.
    Rgb8 {
        /// The samples.
        samples: Vec<[u8; 3]>,
        /// Their linear values.
        table: SampleTable,
    },
    /// One 8-bit sample per texel, read through `table`, standing for red, green and blue.
    Grey8 {
        /// The samples.
        samples: Vec<u8>,
        /// Their linear values.
        table: SampleTable,
    },
}

impl Texels {
    /// Linear RGB texels, kept as one value per texel if red, green and blue are the same numbers in every texel.
    pub fn from_rgb(pixels: Vec<[f32; 3]>) -> Self {
        let same = |p: &[f32; 3]| p[0].to_bits() == p[1].to_bits() && p[0].to_bits() == p[2].to_bits();
        if pixels.iter().all(same) {
            Texels::Grey(pixels.iter().map(|p| p[0]).collect())
        } else {
            Texels::Rgb(pixels)
        }
    }

    /// 8-bit RGB samples read through `table`, kept as one sample per texel if the three are equal in every texel.
    pub fn from_rgb8(samples: Vec<[u8; 3]>, table: SampleTable) -> Self {
        if samples.iter().all(|p| p[0] == p[1] && p[0] == p[2]) {
            Texels::Grey8 { samples: samples.iter().map(|p| p[0]).collect(), table }
        } else {
            Texels::Rgb8 { samples, table }
        }
    }

    /// The number of texels.
    pub fn len(&self) -> usize {
        match self {
            Texels::Rgb(v) => v.len(),
            Texels::Grey(v) => v.len(),
            Texels::Rgb8 { samples, .. } => samples.len(),
            Texels::Grey8 { samples, .. } => samples.len(),
        }
    }

    /// Whether there are no texels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Texel `i` as linear RGB. Panics if `i` is not below [`Texels::len`].
    #[inline]
    pub fn get(&self, i: usize) -> [f32; 3] {
        match self {
            Texels::Rgb(v) => v[i],
            Texels::Grey(v) => [v[i]; 3],
            Texels::Rgb8 { samples, table } => samples[i].map(|s| table[usize::from(s)]),
            Texels::Grey8 { samples, table } => [table[usize::from(samples[i])]; 3],
        }
    }

    /// The texels in order, as linear RGB.
    pub fn iter(&self) -> impl Iterator<Item = [f32; 3]> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    /// The bytes the texels take (without their table).
    pub fn bytes(&self) -> usize {
        match self {
            Texels::Rgb(v) => std::mem::size_of_val(v.as_slice()),
            Texels::Grey(v) => std::mem::size_of_val(v.as_slice()),
            Texels::Rgb8 { samples, .. } => std::mem::size_of_val(samples.as_slice()),
            Texels::Grey8 { samples, .. } => samples.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compact_texels_read_as_the_linear_values_they_stand_for() {
        let table = sample_table(|v| v * v);
        let rgb8 = Texels::from_rgb8(vec![[0, 128, 255], [7, 7, 7]], table.clone());
        assert!(matches!(rgb8, Texels::Rgb8 { .. }));
        let expect = |s: u8| ((f64::from(s) / 255.0).powi(2)) as f32;
        assert_eq!(rgb8.get(0), [expect(0), expect(128), expect(255)]);
        assert_eq!(rgb8.get(1), [expect(7); 3]);
        assert_eq!(rgb8.bytes(), 6);

        let grey8 = Texels::from_rgb8(vec![[9, 9, 9], [200, 200, 200]], table);
        assert!(matches!(grey8, Texels::Grey8 { .. }), "equal samples keep one per texel");
        assert_eq!(grey8.iter().collect::<Vec<_>>(), vec![[expect(9); 3], [expect(200); 3]]);
        assert_eq!(grey8.bytes(), 2);

        let grey = Texels::from_rgb(vec![[0.25; 3], [-0.0; 3]]);
        assert!(matches!(grey, Texels::Grey(_)));
        assert_eq!(grey.get(1)[2].to_bits(), (-0.0f32).to_bits(), "the values are kept bit for bit");
        // One channel that differs, even by its sign, keeps all three.
        let rgb = Texels::from_rgb(vec![[0.25; 3], [0.0, -0.0, 0.0]]);
        assert!(matches!(rgb, Texels::Rgb(_)));
        assert_eq!((rgb.len(), rgb.bytes()), (2, 24));
    }
}
