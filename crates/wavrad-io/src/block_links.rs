//! Blocks of projected links as bytes: how the links of one block of a
//! planned solve ([`Plan::project`]) travel from the process that projected
//! them to the one that finishes the solve ([`Plan::finish`]).
//!
//! A block is a header and the [`BlockLinks`], both in
//! [postcard](https://docs.rs/postcard) (integers as varints, floats as
//! their IEEE bytes, so links come back bit for bit). The header names the
//! format and its version, and the plan the block was projected from by its
//! [`plan_fingerprint`]: a block projected from another scene, other
//! settings or another linking is refused, not solved into a wrong image.
//!
//! ```
//! use wavrad_core::progress::Silent;
//! use wavrad_core::solve::{plan, SolveSettings};
//! use wavrad_io::block_links::{decode_block, encode_block, plan_fingerprint};
//!
//! let scene = wavrad_core::testing::light_over_a_corner(0.3);
//! let plan = plan(&scene, &SolveSettings::default(), &Silent).unwrap();
//! let fingerprint = plan_fingerprint(&plan);
//! let links = plan.project(plan.items(), &Silent).unwrap();
//! let bytes = encode_block(fingerprint, &links);
//! assert_eq!(decode_block(&bytes, fingerprint).unwrap(), links);
//! assert!(decode_block(&bytes, fingerprint ^ 1).is_err());
//! ```

use crate::{Error, Result};
use postcard::ser_flavors::Flavor;
use serde::{Deserialize, Serialize};
use wavrad_core::setting::Described;
use wavrad_core::solve::{BlockLinks, Plan};

/// The first bytes of every block.
const MAGIC: [u8; 8] = *b"wavradBL";

/// The format's version; a change of [`BlockLinks`] or of the link types
/// it holds needs a new one.
const VERSION: u16 = 1;

/// What comes before the links.
#[derive(Serialize, Deserialize)]
struct Header {
    magic: [u8; 8],
    version: u16,
    plan: u32,
}

/// The plan's fingerprint: the CRC-32 of its settings (every described one
/// and the quadrature), its surface count and its items (element pairs
/// and surface triples). Workers that re-plan from the same scene file and
/// settings get the same fingerprint; one whose scene or settings differ
/// gets another.
pub fn plan_fingerprint(plan: &Plan) -> u32 {
    let settings = plan.settings();
    let quadrature = (settings.quadrature.points, settings.quadrature.rays);
    let planned = (
        settings.values(),
        quadrature,
        plan.scene().surfaces.len(),
        plan.element_pairs(),
        plan.triples(),
    );
    postcard::serialize_with_flavor(&planned, Crc32(crc32fast::Hasher::new()))
        .expect("postcard serialises settings and items into a checksum")
}

/// A postcard flavor that feeds the bytes to a CRC-32 instead of storing
/// them.
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

/// The bytes of `links`, projected from the plan whose fingerprint is
/// `plan`.
pub fn encode_block(plan: u32, links: &BlockLinks) -> Vec<u8> {
    let header = Header {
        magic: MAGIC,
        version: VERSION,
        plan,
    };
    postcard::to_allocvec(&(header, links)).expect("postcard encodes every block in memory")
}

/// The links in `bytes`, checked to be a block of this format projected
/// from the plan whose fingerprint is `plan`.
pub fn decode_block(bytes: &[u8], plan: u32) -> Result<BlockLinks> {
    let invalid = |message: String| Error::BlockLinks { message };
    let not_a_block = || {
        invalid(format!(
            "{} bytes that are not a block of wavrad links",
            bytes.len()
        ))
    };
    let (header, rest) = postcard::take_from_bytes::<Header>(bytes).map_err(|_| not_a_block())?;
    if header.magic != MAGIC {
        return Err(not_a_block());
    }
    if header.version != VERSION {
        return Err(invalid(format!(
            "format version {}, this wavrad reads version {VERSION}",
            header.version
        )));
    }
    if header.plan != plan {
        return Err(invalid(format!(
            "projected from another plan (fingerprint {:08x}, this plan's {plan:08x}): the \
             scene, the settings or the linking differ",
            header.plan
        )));
    }
    let (links, rest) = postcard::take_from_bytes::<BlockLinks>(rest)
        .map_err(|e| invalid(format!("damaged after the header: {e}")))?;
    if !rest.is_empty() {
        return Err(invalid(format!(
            "{} stray bytes after the links",
            rest.len()
        )));
    }
    Ok(links)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wavrad_core::progress::Silent;
    use wavrad_core::solve::{plan, SolveSettings};

    /// A glossy floor under a light: two-point links with their children's
    /// shares, and three-point links.
    fn projected(settings: &SolveSettings) -> (u32, BlockLinks) {
        let scene = wavrad_core::testing::mirror_floor_and_light();
        let plan = plan(&scene, settings, &Silent).unwrap();
        (
            plan_fingerprint(&plan),
            plan.project(plan.items(), &Silent).unwrap(),
        )
    }

    #[test]
    fn blocks_round_trip_bit_for_bit() {
        let (fingerprint, links) = projected(&SolveSettings::default());
        assert!(links.two_point.iter().any(|l| l.children.is_some()));
        assert!(!links.three_point.is_empty());
        let bytes = encode_block(fingerprint, &links);
        assert_eq!(decode_block(&bytes, fingerprint).unwrap(), links);
    }

    #[test]
    fn fingerprints_tell_plans_apart() {
        let settings = SolveSettings::default();
        let (fingerprint, _) = projected(&settings);
        assert_eq!(projected(&settings).0, fingerprint);
        let finer = SolveSettings {
            three_point_threshold: settings.three_point_threshold / 2.0,
            ..settings
        };
        assert_ne!(projected(&finer).0, fingerprint);
        let scene = wavrad_core::testing::light_over_a_corner(0.3);
        let other = plan(&scene, &settings, &Silent).unwrap();
        assert_ne!(plan_fingerprint(&other), fingerprint);
    }

    #[test]
    fn damaged_and_foreign_blocks_are_refused() {
        let (fingerprint, links) = projected(&SolveSettings::default());
        let bytes = encode_block(fingerprint, &links);
        let message = |bytes: &[u8], plan: u32| match decode_block(bytes, plan) {
            Err(Error::BlockLinks { message }) => message,
            other => panic!("not refused: {other:?}"),
        };
        assert!(message(&bytes, fingerprint ^ 1).contains("another plan"));
        assert!(message(&bytes[..bytes.len() - 3], fingerprint).contains("damaged"));
        assert!(message(&[bytes.clone(), vec![0]].concat(), fingerprint).contains("stray"));
        assert!(message(b"not links", fingerprint).contains("not a block"));
        let mut newer = bytes.clone();
        newer[MAGIC.len()] = 2;
        assert!(message(&newer, fingerprint).contains("version 2"));
    }
}
