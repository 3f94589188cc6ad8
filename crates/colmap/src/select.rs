//! Selecting one camera's images in a model: by COLMAP camera id or by image-name prefix.
//!
//! A text made only of digits (`"2"`) is a camera id; anything else is an image-name prefix
//! (`"cam_out/"`, the naming of COLMAP's rig configuration). The **key** of an image is its
//! name without the prefix; for a camera-id selector, without everything up to and including
//! the first `/` (the whole name if there is none). Images of two cameras taken at the same
//! instant share a key (`cam_out/000123.png` ↔ `cam_in/000123.png`), which is how `calibrate`
//! and `measure` pair them into epochs.
//!
//! ```
//! use crashrig_colmap::CameraSelector;
//! let out = CameraSelector::parse("cam_out/");
//! assert_eq!(out.key("cam_out/000123.png"), "000123.png");
//! let by_id = CameraSelector::parse("2");
//! assert_eq!(by_id, CameraSelector::CameraId(2));
//! assert_eq!(by_id.key("cam_in/000123.png"), "000123.png");
//! assert_eq!(by_id.to_string(), "2");
//! ```

use crate::Image;

/// Which images belong to a camera.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraSelector {
    /// Images whose name starts with this prefix.
    Prefix(String),
    /// Images taken by this COLMAP camera id.
    CameraId(u32),
}

impl CameraSelector {
    /// Parses a selector: digits only (and within `u32`) → [`CameraSelector::CameraId`], else
    /// a prefix.
    pub fn parse(text: &str) -> Self {
        if !text.is_empty()
            && text.bytes().all(|b| b.is_ascii_digit())
            && let Ok(id) = text.parse::<u32>()
        {
            return Self::CameraId(id);
        }
        Self::Prefix(text.to_string())
    }

    /// True when `image` belongs to this camera.
    pub fn matches(&self, image: &Image) -> bool {
        match self {
            Self::Prefix(p) => image.name.starts_with(p.as_str()),
            Self::CameraId(id) => image.camera_id == *id,
        }
    }

    /// The key of an image of this camera: its name without the prefix (see the module doc).
    pub fn key<'a>(&self, name: &'a str) -> &'a str {
        match self {
            Self::Prefix(p) => name.strip_prefix(p.as_str()).unwrap_or(name),
            Self::CameraId(_) => name.split_once('/').map_or(name, |(_, rest)| rest),
        }
    }
}

impl std::fmt::Display for CameraSelector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Prefix(p) => f.write_str(p),
            Self::CameraId(id) => write!(f, "{id}"),
        }
    }
}

/// The epoch name of an epoch key: the key without its extension (the part after the last `.`
/// of its last path component), if that leaves something (`000123.png` → `000123`). `measure`
/// and `covariance` key camera A's epochs by it.
pub fn epoch_name(key: &str) -> &str {
    let last = key.rsplit('/').next().unwrap_or(key);
    match last.rfind('.') {
        Some(dot) if dot > 0 => &key[..key.len() - (last.len() - dot)],
        _ => key,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(name: &str, camera_id: u32) -> Image {
        Image {
            image_id: 1,
            stored_cam_from_world: crate::RawPose::IDENTITY,
            camera_id,
            name: name.to_string(),
            points2d: Vec::new(),
        }
    }

    #[test]
    fn digits_are_a_camera_id_anything_else_a_prefix() {
        assert_eq!(CameraSelector::parse("17"), CameraSelector::CameraId(17));
        assert_eq!(
            CameraSelector::parse("cam2/"),
            CameraSelector::Prefix("cam2/".into())
        );
        // Too large for a camera id: a prefix, not an error and not a wrapped id.
        assert_eq!(
            CameraSelector::parse("99999999999"),
            CameraSelector::Prefix("99999999999".into())
        );
        assert_eq!(
            CameraSelector::parse(""),
            CameraSelector::Prefix(String::new())
        );
    }

    #[test]
    fn matches_by_prefix_or_by_camera() {
        let a = image("cam_out/000001.png", 1);
        let b = image("cam_in/000001.png", 2);
        let by_prefix = CameraSelector::parse("cam_out/");
        assert!(by_prefix.matches(&a) && !by_prefix.matches(&b));
        let by_id = CameraSelector::parse("2");
        assert!(by_id.matches(&b) && !by_id.matches(&a));
    }

    #[test]
    fn keys_pair_the_images_of_one_instant() {
        let out = CameraSelector::parse("cam_out/");
        let inn = CameraSelector::parse("2");
        assert_eq!(out.key("cam_out/a/000001.png"), "a/000001.png");
        assert_eq!(inn.key("cam_in/a/000001.png"), "a/000001.png");
        // A name without the prefix or without a '/' keeps its whole name.
        assert_eq!(out.key("other.png"), "other.png");
        assert_eq!(inn.key("flat.png"), "flat.png");
    }
}
