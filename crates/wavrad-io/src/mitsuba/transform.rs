//! `<transform>`: `matrix`, `translate`, `rotate`, `scale` and `lookat`
//! composed as Mitsuba does — each element left-multiplies what came before,
//! so `world_from_local = T_last · … · T_first`.

use glam::{DMat3, DMat4, DVec3};
use wavrad_core::scene::Camera;

use super::document::Element;
use super::params::{describe, parse_f64, parse_numbers, parse_xyz};
use crate::error::Result;

/// The matrix of a `<transform>` element.
pub(crate) fn parse_transform(transform: &Element) -> Result<DMat4> {
    let mut world_from_local = DMat4::IDENTITY;
    for e in &transform.children {
        let step = match e.tag.as_str() {
            "matrix" => matrix(e)?,
            "translate" => {
                e.check_attrs(&["value", "x", "y", "z"])?;
                DMat4::from_translation(parse_xyz(e, 0.0)?)
            }
            "scale" => {
                e.check_attrs(&["value", "x", "y", "z"])?;
                DMat4::from_scale(parse_xyz(e, 1.0)?)
            }
            "rotate" => rotate(e)?,
            "lookat" => look_at(e)?,
            other => {
                return Err(e.at.error(format!(
                    "unknown element <{other}> in <transform> (expected matrix, translate, rotate, scale or lookat)"
                )))
            }
        };
        world_from_local = step * world_from_local;
    }
    Ok(world_from_local)
}

/// 16 values (4×4, row-major) or 9 (3×3 linear part).
fn matrix(e: &Element) -> Result<DMat4> {
    e.check_attrs(&["value"])?;
    let v = parse_numbers(e.required_attr("value")?, e)?;
    let row = |r: usize, n: usize| &v[r * n..r * n + n];
    match v.len() {
        16 => Ok(DMat4::from_cols_array(&[
            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10], v[14], v[3], v[7],
            v[11], v[15],
        ])),
        9 => {
            let rows = [row(0, 3), row(1, 3), row(2, 3)];
            let linear = DMat3::from_cols(
                DVec3::new(rows[0][0], rows[1][0], rows[2][0]),
                DVec3::new(rows[0][1], rows[1][1], rows[2][1]),
                DVec3::new(rows[0][2], rows[1][2], rows[2][2]),
            );
            Ok(DMat4::from_mat3(linear))
        }
        n => Err(e.at.error(format!(
            "{} needs 16 values (4x4, row-major) or 9 (3x3), got {n}",
            describe(e)
        ))),
    }
}

/// Right-handed rotation by `angle` degrees about the axis given by `x`,
/// `y`, `z` (or `value`/`axis="x, y, z"`).
fn rotate(e: &Element) -> Result<DMat4> {
    e.check_attrs(&["x", "y", "z", "value", "axis", "angle"])?;
    let axis = match e.attr("axis") {
        Some(text) => match parse_numbers(text, e)?.as_slice() {
            [x, y, z] => DVec3::new(*x, *y, *z),
            other => {
                return Err(e
                    .at
                    .error(format!("<rotate> axis needs 3 values, got {}", other.len())))
            }
        },
        None => parse_xyz(e, 0.0)?,
    };
    let angle = parse_f64(e.required_attr("angle")?, e)?;
    let axis = axis.try_normalize().ok_or_else(|| {
        e.at.error("<rotate> needs a non-zero axis (attributes x, y, z)")
    })?;
    Ok(DMat4::from_axis_angle(axis, angle.to_radians()))
}

/// Mitsuba's `look_at`: camera +z towards the target, +y up, +x left.
fn look_at(e: &Element) -> Result<DMat4> {
    e.check_attrs(&["origin", "target", "up"])?;
    let point = |name: &str| -> Result<DVec3> {
        match parse_numbers(e.required_attr(name)?, e)?.as_slice() {
            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
            other => Err(e.at.error(format!(
                "<lookat> {name} needs 3 values, got {}",
                other.len()
            ))),
        }
    };
    let origin = point("origin")?;
    let target = point("target")?;
    let dir = (target - origin)
        .try_normalize()
        .ok_or_else(|| e.at.error("<lookat> origin and target coincide"))?;
    let up = match e.attr("up") {
        Some(_) => point("up")?,
        None => coordinate_system(dir),
    };
    Camera::look_at(origin, target, up).ok_or_else(|| {
        e.at.error("<lookat> up vector is zero or parallel to the view direction")
    })
}

/// A unit vector perpendicular to unit `n` (Duff et al. 2017), as Mitsuba
/// picks an up vector when `lookat` has none.
fn coordinate_system(n: DVec3) -> DVec3 {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitsuba::document::read_scene_document;
    use glam::DVec4;
    use std::path::Path;

    fn transform(inner: &str) -> Result<DMat4> {
        let xml = format!("<scene><transform name=\"t\">{inner}</transform></scene>");
        let e = read_scene_document(&xml, "t.xml", Path::new("."), None, &[])
            .unwrap()
            .elements;
        parse_transform(&e[0])
    }

    fn close(a: DMat4, b: DMat4) -> bool {
        a.abs_diff_eq(b, 1e-12)
    }

    #[test]
    fn translate_then_rotate_left_multiplies() {
        // Translate by +x, then rotate 90° about z: the point ends up on +y.
        let m = transform(r#"<translate x="1"/><rotate z="1" angle="90"/>"#).unwrap();
        let expected = DMat4::from_cols_array_2d(&[
            [0.0, 1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 1.0],
        ]);
        assert!(close(m, expected), "{m}");
        assert!(m.transform_point3(DVec3::ZERO).abs_diff_eq(DVec3::Y, 1e-12));
        // The other order keeps the translation unrotated.
        let m =
            transform(r#"<rotate value="0 0 1" angle="90"/><translate value="1,0 0"/>"#).unwrap();
        assert!(m.transform_point3(DVec3::ZERO).abs_diff_eq(DVec3::X, 1e-12));
    }

    #[test]
    fn matrix_is_row_major_and_scale_forms() {
        let m = transform(r#"<matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/>"#).unwrap();
        assert_eq!(m.w_axis, DVec4::new(5.0, 6.0, 7.0, 1.0));
        let m = transform(r#"<matrix value="0 -1 0, 1 0 0, 0 0 1"/>"#).unwrap();
        assert!(m.transform_vector3(DVec3::X).abs_diff_eq(DVec3::Y, 1e-12));
        let m = transform(r#"<scale value="2"/><scale y="3"/>"#).unwrap();
        assert_eq!(m, DMat4::from_scale(DVec3::new(2.0, 6.0, 2.0)));
        let m = transform(r#"<scale value="1, 2, 3"/>"#).unwrap();
        assert_eq!(m, DMat4::from_scale(DVec3::new(1.0, 2.0, 3.0)));
    }

    #[test]
    fn lookat_matches_mitsuba() {
        // Cornell-box camera: at z = 3.9 looking at the origin, +y up.
        let m = transform(r#"<lookat origin="0, 0, 3.9" target="0, 0, 0" up="0, 1, 0"/>"#).unwrap();
        let expected = DMat4::from_cols_array_2d(&[
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 0.0],
            [0.0, 0.0, 3.9, 1.0],
        ]);
        assert!(close(m, expected), "{m}");
        // Without up, any orthonormal frame with z towards the target.
        let m = transform(r#"<lookat origin="1 2 3" target="1 2 4"/>"#).unwrap();
        assert!(m.z_axis.truncate().abs_diff_eq(DVec3::Z, 1e-12));
        assert!((m.x_axis.truncate().dot(m.y_axis.truncate())).abs() < 1e-12);
    }

    #[test]
    fn bad_transforms_are_errors() {
        assert!(transform(r#"<lookat origin="0 0 0" target="0 1 0" up="0 1 0"/>"#).is_err());
        assert!(transform(r#"<rotate angle="10"/>"#).is_err());
        assert!(transform(r#"<matrix value="1 2 3"/>"#).is_err());
        let msg = transform(r#"<skew value="1"/>"#).unwrap_err().to_string();
        assert!(msg.contains("<skew>"), "{msg}");
    }
}
