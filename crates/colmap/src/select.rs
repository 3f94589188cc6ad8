//! Selecting one camera's images in a model: by COLMAP camera id or by image-name prefix.
//!
//! A text made only of digits (`"2"`) is a camera id; anything else is an image-name prefix
//! (`"cam_out/"`, the naming of COLMAP's rig configuration). The **key** of an image is its
//! name without the prefix; for a camera-id selector, without everything up to and including
//! the first `/` (the whole name if there is none). Images of two cameras taken at the same
//! instant share a key (`cam_out/000123.png` ↔ `cam_in/000123.png`), which is how `calibrate`
//! and `measure` pair them into epochs.
//!
//! Names are compared in Unicode normal form C ([`nfc`]): a prefix typed composed (`Cópia de`)
//! finds the images of a model whose names were stored decomposed (as macOS writes file names),
//! and the other way round; the key is the rest of the name as the model stores it. When a
//! selector matches nothing, [`CameraSelector::suggestions`] names what the model has nearest.
//!
//! ```
//! use crashrig_colmap::CameraSelector;
//! let out = CameraSelector::parse("cam_out/");
//! assert_eq!(out.key("cam_out/000123.png"), "000123.png");
//! let by_id = CameraSelector::parse("2");
//! assert_eq!(by_id, CameraSelector::CameraId(2));
//! assert_eq!(by_id.key("cam_in/000123.png"), "000123.png");
//! assert_eq!(by_id.to_string(), "2");
//! // Composed `ó` (U+00F3) typed, decomposed `o` + U+0301 stored: the same name in NFC.
//! let typed = CameraSelector::parse("C\u{f3}pia de ");
//! assert_eq!(typed.key("Co\u{301}pia de IMG_5143.png"), "IMG_5143.png");
//! ```

use crate::Image;
use std::borrow::Cow;
use std::collections::BTreeMap;
use unicode_normalization::{UnicodeNormalization, is_nfc};

/// `text` in Unicode normal form C (canonical composition): how image names and prefixes are
/// compared. Borrowed when it already is (every ASCII text is).
pub fn nfc(text: &str) -> Cow<'_, str> {
    if is_nfc(text) {
        Cow::Borrowed(text)
    } else {
        Cow::Owned(text.nfc().collect())
    }
}

/// The byte length of the beginning of `name` that `prefix` matches, or `None`: a byte-exact
/// match as before, else equal in NFC at a boundary of `name` where normalising the two parts
/// separately gives the normalised whole (no character composes across it).
fn prefix_end(name: &str, prefix: &str) -> Option<usize> {
    if name.starts_with(prefix) {
        return Some(prefix.len());
    }
    if name.is_ascii() && prefix.is_ascii() {
        return None;
    }
    let want = nfc(prefix);
    let whole = nfc(name);
    if !whole.starts_with(want.as_ref()) {
        return None;
    }
    name.char_indices()
        .map(|(i, _)| i)
        .skip(1)
        .chain(std::iter::once(name.len()))
        .find(|&i| {
            let head = nfc(&name[..i]);
            head == want && format!("{head}{}", nfc(&name[i..])) == whole
        })
}

/// Image-name beginnings (or camera ids) listed by [`CameraSelector::suggestions`].
const SUGGESTIONS: usize = 3;

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

    /// True when `image` belongs to this camera (names compared in NFC).
    pub fn matches(&self, image: &Image) -> bool {
        match self {
            Self::Prefix(p) => prefix_end(&image.name, p).is_some(),
            Self::CameraId(id) => image.camera_id == *id,
        }
    }

    /// The key of an image of this camera: its name without the prefix (see the module doc).
    pub fn key<'a>(&self, name: &'a str) -> &'a str {
        match self {
            Self::Prefix(p) => prefix_end(name, p).map_or(name, |end| &name[end..]),
            Self::CameraId(_) => name.split_once('/').map_or(name, |(_, rest)| rest),
        }
    }

    /// True for a prefix that is empty or only white space: it would select every image. Front
    /// ends refuse it, naming their flag or key.
    pub fn is_blank(&self) -> bool {
        matches!(self, Self::Prefix(p) if p.trim().is_empty())
    }

    /// A hint for a prefix written without its trailing slash: when this is a prefix that does
    /// not end in `/` and every image name it matches continues with `/` right after it (a
    /// directory), the selector with the slash. Without the slash the prefix still selects
    /// the images, but their keys keep the `/` (`cam_out` + `/0001.png`), so they pair with
    /// nothing that was selected with the slash. `None` otherwise.
    ///
    /// ```
    /// use crashrig_colmap::{CameraSelector, Image, RawPose};
    /// let image = |name: &str| Image {
    ///     image_id: 1,
    ///     stored_cam_from_world: RawPose::IDENTITY,
    ///     camera_id: 1,
    ///     name: name.into(),
    ///     points2d: vec![],
    /// };
    /// let images = [image("cam_out/0001.png"), image("cam_in/0001.png")];
    /// let hint = CameraSelector::parse("cam_out").slash_hint(&images);
    /// assert_eq!(hint.as_deref(), Some("`cam_out` is a directory of the image names: write `cam_out/`"));
    /// assert_eq!(CameraSelector::parse("cam_out/").slash_hint(&images), None);
    /// assert_eq!(CameraSelector::parse("cam_").slash_hint(&images), None);
    /// ```
    pub fn slash_hint(&self, images: &[Image]) -> Option<String> {
        let Self::Prefix(p) = self else { return None };
        if p.is_empty() || p.ends_with('/') {
            return None;
        }
        let mut matched = images
            .iter()
            .filter_map(|i| prefix_end(&i.name, p).map(|end| &i.name[end..]))
            .peekable();
        matched.peek()?;
        matched
            .all(|rest| rest.starts_with('/'))
            .then(|| format!("`{p}` is a directory of the image names: write `{p}/`"))
    }

    /// What `images` offer nearest to this selector, for the error when it matches none: the
    /// image-name beginnings nearest to the prefix (each image's beginning, 2 characters shorter
    /// to 2 longer than the prefix, at the least Levenshtein distance in NFC; ties by the number
    /// of images), or the
    /// camera ids that have images (most images first); at most three, each with its number
    /// of images. Empty when the model has no image.
    ///
    /// ```
    /// use crashrig_colmap::{CameraSelector, Image, RawPose};
    /// let image = |name: &str| Image {
    ///     image_id: 1,
    ///     stored_cam_from_world: RawPose::IDENTITY,
    ///     camera_id: 1,
    ///     name: name.into(),
    ///     points2d: vec![],
    /// };
    /// let images = [image("cam_out/0001.png"), image("cam_out/0002.png"), image("cam_in/0001.png")];
    /// let s = CameraSelector::parse("cam_ot/").suggestions(&images);
    /// assert_eq!(s, "nearest image-name beginnings: `cam_out/` (2 images), `cam_in/` (1 image)");
    /// ```
    pub fn suggestions(&self, images: &[Image]) -> String {
        let count = |n: usize| format!("{n} image{}", if n == 1 { "" } else { "s" });
        match self {
            Self::CameraId(_) => {
                let mut by_id: BTreeMap<u32, usize> = BTreeMap::new();
                for im in images {
                    *by_id.entry(im.camera_id).or_default() += 1;
                }
                let mut ids: Vec<(u32, usize)> = by_id.into_iter().collect();
                ids.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
                if ids.is_empty() {
                    return String::new();
                }
                let listed: Vec<String> = ids
                    .iter()
                    .take(SUGGESTIONS)
                    .map(|(id, n)| format!("{id} ({})", count(*n)))
                    .collect();
                format!("camera ids with images: {}", listed.join(", "))
            }
            Self::Prefix(p) => {
                let want: Vec<char> = nfc(p).chars().collect();
                let typed: String = want.iter().collect();
                // Beginning → (distance, images).
                let mut heads: BTreeMap<String, (usize, usize)> = BTreeMap::new();
                for im in images {
                    let name: Vec<char> = nfc(&im.name).chars().collect();
                    let lo = want.len().saturating_sub(2).max(1);
                    let hi = (want.len() + 2).min(name.len());
                    // This image's nearest beginning (ties: the length nearest the prefix's).
                    let nearest = (lo..=hi)
                        .map(|len| {
                            let head: String = name[..len].iter().collect();
                            (
                                strsim::levenshtein(&head, &typed),
                                len.abs_diff(want.len()),
                                head,
                            )
                        })
                        .min();
                    if let Some((d, _, head)) = nearest {
                        heads.entry(head).or_insert((d, 0)).1 += 1;
                    }
                }
                let mut best: Vec<(String, usize, usize)> =
                    heads.into_iter().map(|(h, (d, n))| (h, d, n)).collect();
                best.sort_by(|a, b| a.1.cmp(&b.1).then(b.2.cmp(&a.2)).then(a.0.cmp(&b.0)));
                if best.is_empty() {
                    return String::new();
                }
                let listed: Vec<String> = best
                    .iter()
                    .take(SUGGESTIONS)
                    .map(|(h, _, n)| format!("`{h}` ({})", count(*n)))
                    .collect();
                format!("nearest image-name beginnings: {}", listed.join(", "))
            }
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

    /// Issue 36: a prefix typed in another Unicode normal form than the model's names.
    #[test]
    fn names_are_compared_in_nfc() {
        let composed = "C\u{f3}pia de IMG_5143.png";
        let decomposed = "Co\u{301}pia de IMG_5143.png";
        assert_ne!(composed, decomposed);
        for (typed, stored) in [
            ("C\u{f3}pia de ", decomposed),
            ("Co\u{301}pia de ", composed),
            ("C\u{f3}pia de ", composed),
        ] {
            let sel = CameraSelector::parse(typed);
            assert!(sel.matches(&image(stored, 1)), "{typed:?} {stored:?}");
            assert_eq!(sel.key(stored), "IMG_5143.png");
        }
        // An accent is not a prefix of the accented letter.
        let sel = CameraSelector::parse("Co");
        assert!(!sel.matches(&image(composed, 1)));
        assert_eq!(sel.key(composed), composed);
        // A boundary inside a composed character is no boundary.
        let sel = CameraSelector::parse("C\u{f3}");
        assert!(sel.matches(&image(decomposed, 1)));
        assert_eq!(sel.key(decomposed), "pia de IMG_5143.png");
        assert_eq!(nfc(decomposed), composed);
        assert!(matches!(nfc("cam_out/1.png"), Cow::Borrowed(_)));
    }

    #[test]
    fn blank_prefixes_are_blank() {
        assert!(CameraSelector::parse("").is_blank());
        assert!(CameraSelector::parse(" \t").is_blank());
        assert!(!CameraSelector::parse("cam/").is_blank());
        assert!(!CameraSelector::parse("0").is_blank());
    }

    #[test]
    fn suggestions_name_the_nearest_beginnings_or_the_camera_ids() {
        let images = [
            image("Co\u{301}pia de IMG_1.png", 1),
            image("Co\u{301}pia de IMG_2.png", 1),
            image("cam_in/0001.png", 2),
        ];
        assert_eq!(
            CameraSelector::parse("Copia de ").suggestions(&images),
            "nearest image-name beginnings: `C\u{f3}pia de ` (2 images), `cam_in/00` (1 image)"
        );
        assert_eq!(
            CameraSelector::parse("7").suggestions(&images),
            "camera ids with images: 1 (2 images), 2 (1 image)"
        );
        assert_eq!(CameraSelector::parse("x").suggestions(&[]), "");
    }

    /// Issue 36: an image looked up by a name in another normal form; the nearest names when
    /// none matches.
    #[test]
    fn image_names_are_found_in_nfc() {
        let mut a = image("Co\u{301}pia de IMG_1.png", 1);
        let mut b = image("cam_in/0001.png", 2);
        a.image_id = 1;
        b.image_id = 2;
        let camera = |camera_id| crate::CameraRecord {
            camera_id,
            camera: crashrig_camera::Camera::new(
                crashrig_camera::ModelId::SimplePinhole,
                100,
                100,
                vec![100.0, 50.0, 50.0],
            )
            .unwrap(),
        };
        let model = crate::Reconstruction::from_records(
            vec![camera(1), camera(2)],
            vec![],
            vec![],
            vec![a, b],
            vec![],
        )
        .unwrap();
        let found = |n: &str| model.image_by_name(n).map(|i| i.image_id);
        assert_eq!(found("C\u{f3}pia de IMG_1.png"), Some(1));
        assert_eq!(found("Co\u{301}pia de IMG_1.png"), Some(1));
        assert_eq!(found("Copia de IMG_1.png"), None);
        assert_eq!(
            model.nearest_image_names("Copia de IMG_1.png", 1),
            vec!["Co\u{301}pia de IMG_1.png"]
        );
        assert_eq!(model.nearest_image_names("cam_in/1.png", 5).len(), 2);
    }
}
