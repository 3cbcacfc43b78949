//! Blocks of a planned solve as bytes: the items a driver sends to a
//! worker ([`BlockItems`], from [`Plan::block_items`]) and the links that
//! come back ([`BlockLinks`], from [`Projector::project`] or
//! [`Plan::project`]) for [`Plan::finish`].
//!
//! A block is a header and its body, both in
//! [postcard](https://docs.rs/postcard) (integers as varints, floats as
//! their IEEE bytes, so links come back bit for bit). The header names the
//! kind and version of the format and what the block was made for, by the
//! [`Fingerprint`]s of the scene and settings and of the plan: a worker
//! refuses items planned for another scene or other settings, and the
//! driver refuses links projected for another plan, instead of solving
//! them into a wrong image.
//!
//! ```
//! use wavrad_core::progress::Silent;
//! use wavrad_core::solve::{plan, Projector, SolveSettings};
//! use wavrad_io::block_links::*;
//!
//! let scene = wavrad_core::testing::light_over_a_corner(0.3);
//! let settings = SolveSettings::default();
//! let plan = plan(&scene, &settings, &Silent).unwrap();
//! let driver = fingerprint(&plan);
//! let items = encode_items(driver, &plan.block_items(plan.items()).unwrap());
//!
//! // A worker, with its own projector of the same scene and settings.
//! let projector = Projector::new(&scene, &settings).unwrap();
//! let (carried, block) = decode_items(&items, projector_fingerprint(&projector)).unwrap();
//! let links = encode_links(carried, &projector.project(&block, &Silent));
//!
//! let decoded = decode_links(&links, driver).unwrap();
//! assert_eq!(decoded.two_point, plan.project(plan.items(), &Silent).unwrap().two_point);
//! ```

use crate::{Error, Result};
use postcard::ser_flavors::Flavor;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use wavrad_core::setting::Described;
use wavrad_core::solve::{BlockItems, BlockLinks, Plan, Projector};

/// The first bytes of a block's items.
const ITEMS: [u8; 8] = *b"wavradBI";

/// The first bytes of a block's links.
const LINKS: [u8; 8] = *b"wavradBL";

/// The format's version; a change of [`BlockItems`], [`BlockLinks`] or of
/// the types they hold needs a new one.
const VERSION: u16 = 1;

/// What a block was made for, as its header names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// Of the scene and settings ([`projector_fingerprint`]).
    pub projector: u32,
    /// Of the plan: that and its items ([`fingerprint`]).
    pub plan: u32,
}

/// What comes before the items or links.
#[derive(Serialize, Deserialize)]
struct Header {
    magic: [u8; 8],
    version: u16,
    fingerprint: Fingerprint,
}

/// The CRC-32 of what a projection depends on besides its items: wavrad's
/// version, the settings (every described one and the quadrature), and
/// the scene's surfaces, camera and film in their `Debug` form (every
/// coordinate and BRDF parameter, floats in their shortest round-trip
/// form). A worker that loaded the same scene file with the same settings
/// gets the same fingerprint; one whose files or settings differ gets
/// another.
pub fn projector_fingerprint(projector: &Projector) -> u32 {
    let settings = projector.settings();
    let described = (
        env!("CARGO_PKG_VERSION"),
        settings.values(),
        (settings.quadrature.points, settings.quadrature.rays),
    );
    let mut crc = Crc32(crc32fast::Hasher::new());
    crc.0
        .update(&postcard::to_allocvec(&described).expect("postcard encodes settings"));
    let scene = projector.scene();
    write!(
        crc,
        "{:?}{:?}{:?}",
        scene.surfaces, scene.camera, scene.film
    )
    .expect("a checksum takes any text");
    crc.0.finalize()
}

/// The fingerprints of `plan`: its projector's, and the CRC-32 of that and
/// the plan's items (element pairs and surface triples).
pub fn fingerprint(plan: &Plan) -> Fingerprint {
    let projector = projector_fingerprint(plan.projector());
    let mut crc = crc32fast::Hasher::new();
    crc.update(&projector.to_le_bytes());
    let items = (plan.element_pairs(), plan.triples());
    let plan = postcard::serialize_with_flavor(&items, Crc32(crc))
        .expect("postcard serialises items into a checksum");
    Fingerprint { projector, plan }
}

/// A CRC-32 that postcard serialises into and `Debug` writes into.
struct Crc32(crc32fast::Hasher);

impl Flavor for Crc32 {
    type Output = u32;

    fn try_push(&mut self, byte: u8) -> postcard::Result<()> {
        self.0.update(&[byte]);
        Ok(())
    }

    fn try_extend(&mut self, bytes: &[u8]) -> postcard::Result<()> {
        self.0.update(bytes);
        Ok(())
    }

    fn finalize(self) -> postcard::Result<u32> {
        Ok(self.0.finalize())
    }
}

impl Write for Crc32 {
    fn write_str(&mut self, text: &str) -> std::fmt::Result {
        self.0.update(text.as_bytes());
        Ok(())
    }
}

/// The bytes of a block's `items`, from the plan whose fingerprints are
/// `fingerprint`.
pub fn encode_items(fingerprint: Fingerprint, items: &BlockItems) -> Vec<u8> {
    encode(ITEMS, fingerprint, items)
}

/// The items in `bytes`, checked to be a block's items made for a scene
/// and settings whose fingerprint is `projector`; with the fingerprints
/// their links must carry back.
pub fn decode_items(bytes: &[u8], projector: u32) -> Result<(Fingerprint, BlockItems)> {
    let (fingerprint, items) = decode(bytes, ITEMS, "items")?;
    if fingerprint.projector != projector {
        return Err(Error::BlockLinks {
            message: format!(
                "items planned for another scene or other settings (fingerprint {:08x}, this \
                 projector's {projector:08x}): the scene files, the settings or wavrad differ",
                fingerprint.projector
            ),
        });
    }
    Ok((fingerprint, items))
}

/// The bytes of a block's `links`, projected for the plan whose
/// fingerprints are `fingerprint`.
pub fn encode_links(fingerprint: Fingerprint, links: &BlockLinks) -> Vec<u8> {
    encode(LINKS, fingerprint, links)
}

/// The links in `bytes`, checked to be a block's links projected for the
/// plan whose fingerprints are `fingerprint`.
pub fn decode_links(bytes: &[u8], fingerprint: Fingerprint) -> Result<BlockLinks> {
    let (theirs, links) = decode(bytes, LINKS, "links")?;
    if theirs != fingerprint {
        return Err(Error::BlockLinks {
            message: format!(
                "projected for another plan (fingerprint {:08x}, this plan's {:08x}): the \
                 scene, the settings or the linking differ",
                theirs.plan, fingerprint.plan
            ),
        });
    }
    Ok(links)
}

fn encode<T: Serialize>(magic: [u8; 8], fingerprint: Fingerprint, body: &T) -> Vec<u8> {
    let header = Header {
        magic,
        version: VERSION,
        fingerprint,
    };
    postcard::to_allocvec(&(header, body)).expect("postcard encodes every block in memory")
}

/// The fingerprints and body of the block in `bytes`, of the kind `magic`
/// names (`what`, in messages).
fn decode<T: DeserializeOwned>(
    bytes: &[u8],
    magic: [u8; 8],
    what: &str,
) -> Result<(Fingerprint, T)> {
    let invalid = |message: String| Error::BlockLinks { message };
    let not_a_block = || {
        invalid(format!(
            "{} bytes that are not a block of wavrad {what}",
            bytes.len()
        ))
    };
    let (header, rest) = postcard::take_from_bytes::<Header>(bytes).map_err(|_| not_a_block())?;
    if header.magic != magic {
        return Err(not_a_block());
    }
    if header.version != VERSION {
        return Err(invalid(format!(
            "format version {}, this wavrad reads version {VERSION}",
            header.version
        )));
    }
    let (body, rest) = postcard::take_from_bytes::<T>(rest)
        .map_err(|e| invalid(format!("damaged after the header: {e}")))?;
    if !rest.is_empty() {
        return Err(invalid(format!(
            "{} stray bytes after the {what}",
            rest.len()
        )));
    }
    Ok((header.fingerprint, body))
}

#[cfg(test)]
mod tests {
    use super::*;
    use wavrad_core::progress::Silent;
    use wavrad_core::solve::{plan, SolveSettings};

    /// A glossy floor under a light: two-point links with their children's
    /// shares, and three-point links.
    fn planned(settings: &SolveSettings) -> Plan {
        let scene = wavrad_core::testing::mirror_floor_and_light();
        plan(&scene, settings, &Silent).unwrap()
    }

    #[test]
    fn blocks_round_trip_bit_for_bit() {
        let plan = planned(&SolveSettings::default());
        let fingerprint = fingerprint(&plan);
        let items = plan.block_items(plan.items()).unwrap();
        let bytes = encode_items(fingerprint, &items);
        assert_eq!(
            decode_items(&bytes, fingerprint.projector).unwrap(),
            (fingerprint, items)
        );
        let links = plan.project(plan.items(), &Silent).unwrap();
        assert!(links.two_point.iter().any(|l| l.children.is_some()));
        assert!(!links.three_point.is_empty());
        let bytes = encode_links(fingerprint, &links);
        assert_eq!(decode_links(&bytes, fingerprint).unwrap(), links);
    }

    #[test]
    fn fingerprints_tell_scenes_settings_and_plans_apart() {
        let settings = SolveSettings::default();
        let base = fingerprint(&planned(&settings));
        assert_eq!(fingerprint(&planned(&settings)), base);
        let finer = SolveSettings {
            three_point_threshold: settings.three_point_threshold / 2.0,
            ..settings
        };
        let other = fingerprint(&planned(&finer));
        assert_ne!(other.projector, base.projector);
        assert_ne!(other.plan, base.plan);
        let mut scene = wavrad_core::testing::mirror_floor_and_light();
        scene.surfaces[1].emission.0[2] *= 1.0 + f64::EPSILON;
        let brighter = fingerprint(&plan(&scene, &settings, &Silent).unwrap());
        assert_ne!(brighter.projector, base.projector);
    }

    #[test]
    fn damaged_and_foreign_blocks_are_refused() {
        let plan = planned(&SolveSettings::default());
        let fingerprint = fingerprint(&plan);
        let links = encode_links(fingerprint, &plan.project(plan.items(), &Silent).unwrap());
        let items = encode_items(fingerprint, &plan.block_items(0..1).unwrap());
        let message = |result: Result<_>| match result {
            Err(Error::BlockLinks { message }) => message,
            Err(e) => panic!("another error: {e}"),
            Ok(()) => panic!("not refused"),
        };
        let links_for = |bytes: &[u8], f| decode_links(bytes, f).map(|_| ());
        let other_plan = Fingerprint {
            plan: fingerprint.plan ^ 1,
            ..fingerprint
        };
        assert!(message(links_for(&links, other_plan)).contains("another plan"));
        let truncated = &links[..links.len() - 3];
        assert!(message(links_for(truncated, fingerprint)).contains("damaged"));
        let longer = [links.clone(), vec![0]].concat();
        assert!(message(links_for(&longer, fingerprint)).contains("stray"));
        assert!(message(links_for(b"not links", fingerprint)).contains("not a block"));
        assert!(message(links_for(&items, fingerprint)).contains("not a block of wavrad links"));
        let mut newer = links.clone();
        newer[LINKS.len()] = 2;
        assert!(message(links_for(&newer, fingerprint)).contains("version 2"));
        let items_for = |p| decode_items(&items, p).map(|_| ());
        assert!(message(items_for(fingerprint.projector ^ 1)).contains("another scene"));
    }
}
