//! A polar plot of light directions as inline SVG (text set by the browser).
//!
//! A direction l = (x, y, z) (surface → light, camera frame: x right, y up, z toward the
//! camera) is drawn at radius θ = acos z (its angle from the view axis, 90° at the rim) and
//! azimuth atan2(y, x), so the plot is the lights as seen from the camera.

use std::fmt::Write as _;

/// Side of the SVG in CSS pixels.
const SIDE: f64 = 300.0;
/// Radius of the 90° ring.
const R90: f64 = 120.0;

/// Position in the SVG of direction `l`.
fn place(l: [f32; 3]) -> (f64, f64) {
    let [x, y, z] = l.map(f64::from);
    let theta = z.clamp(-1.0, 1.0).acos().to_degrees();
    let phi = y.atan2(x);
    let r = R90 * theta / 90.0;
    (SIDE / 2.0 + r * phi.cos(), SIDE / 2.0 - r * phi.sin())
}

/// The SVG markup (no scripts, no external references).
pub(crate) fn lights_svg(directions: &[[f32; 3]]) -> String {
    let c = SIDE / 2.0;
    let mut s = format!(
        "<svg class=\"polar\" width=\"{SIDE}\" height=\"{SIDE}\" \
         viewBox=\"0 0 {SIDE} {SIDE}\" font-family=\"sans-serif\" font-size=\"11\">\
         <rect width=\"{SIDE}\" height=\"{SIDE}\" fill=\"#fff\"/>"
    );
    for deg in [30.0, 60.0, 90.0] {
        let r = R90 * deg / 90.0;
        let _ = write!(
            s,
            "<circle cx=\"{c}\" cy=\"{c}\" r=\"{r}\" fill=\"none\" stroke=\"#bbb\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" fill=\"#777\">{deg}°</text>",
            c + r * 0.72 + 2.0,
            c - r * 0.72 - 2.0
        );
    }
    let _ = write!(
        s,
        "<line x1=\"{}\" y1=\"{c}\" x2=\"{}\" y2=\"{c}\" stroke=\"#ddd\"/>\
         <line x1=\"{c}\" y1=\"{}\" x2=\"{c}\" y2=\"{}\" stroke=\"#ddd\"/>\
         <text x=\"{}\" y=\"{}\" fill=\"#555\">+x</text><text x=\"{}\" y=\"14\" fill=\"#555\">+y</text>",
        c - R90,
        c + R90,
        c - R90,
        c + R90,
        c + R90 + 6.0,
        c + 4.0,
        c + 4.0
    );
    for (i, &l) in directions.iter().enumerate() {
        let (x, y) = place(l);
        let _ = write!(
            s,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"4\" fill=\"#d9480f\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" fill=\"#222\">{}</text>",
            x + 5.0,
            y - 4.0,
            i + 1
        );
    }
    s.push_str("</svg>");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_land_at_their_angle_and_azimuth() {
        let c = SIDE / 2.0;
        // Straight at the camera: the centre.
        let (x, y) = place([0.0, 0.0, 1.0]);
        assert!((x - c).abs() < 1e-9 && (y - c).abs() < 1e-9);
        // 60° from the view axis toward +y (up): 2/3 of the way to the rim, straight up.
        let t = 60f32.to_radians();
        let (x, y) = place([0.0, t.sin(), t.cos()]);
        assert!((x - c).abs() < 1e-4, "{x}");
        assert!((c - y - R90 * 2.0 / 3.0).abs() < 1e-3, "{y}");
        // 30° toward +x: right of the centre on the 30° ring.
        let t = 30f32.to_radians();
        let (x, y) = place([t.sin(), 0.0, t.cos()]);
        assert!((x - c - R90 / 3.0).abs() < 1e-3 && (y - c).abs() < 1e-4);
        let svg = lights_svg(&[[0.0, 0.0, 1.0], [0.5, 0.0, 0.866]]);
        assert_eq!(svg.matches("fill=\"#d9480f\"").count(), 2);
        assert!(!svg.contains("<script"));
    }
}
