//! The HTML report is one self-contained page whose pictures and mesh decode back to the
//! data that went in.
#![cfg(feature = "report")]

use base64::Engine as _;
use photostereo::image::{gradient_to_normal, pixel_to_xy, Image, Mask};
use photostereo::report::{MeshParts, Report, Section, MAX_TRIANGLES};
use photostereo::Error;

fn b64(s: &str) -> Vec<u8> {
    base64::engine::general_purpose::STANDARD
        .decode(s)
        .expect("valid base64")
}

/// Every `src="..."` / `href="..."` value of the page.
fn urls(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for key in ["src=\"", "href=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(key) {
            rest = &rest[i + key.len()..];
            out.push(rest[..rest.find('"').unwrap()].to_string());
        }
    }
    out
}

/// Decode the `n`-th inlined PNG of the page.
fn png(html: &str, n: usize) -> image::RgbImage {
    let uri = urls(html)
        .into_iter()
        .filter(|u| u.starts_with("data:image/png;base64,"))
        .nth(n)
        .expect("enough pictures");
    image::load_from_memory(&b64(&uri["data:image/png;base64,".len()..]))
        .unwrap()
        .to_rgb8()
}

fn cap(w: usize, h: usize, radius: f64) -> Image<f32> {
    Image::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let z2 = radius * radius - x * x - y * y;
        if z2 > 0.0 {
            z2.sqrt() as f32
        } else {
            f32::NAN
        }
    })
}

#[test]
fn page_is_self_contained_and_pictures_decode_to_the_maps() {
    let (w, h) = (64, 48);
    let depth = cap(w, h, 20.0);
    let mask: Mask = depth.map(|z| z.is_finite());
    let normals = Image::from_fn(w, h, |r, c| {
        let (x, y) = pixel_to_xy(r, c, w, h);
        let z = f64::from(*depth.get(r, c));
        gradient_to_normal((-x / z) as f32, (-y / z) as f32)
    });
    let mut report = Report::new("cap <test>");
    report.normals(&normals, Some(&mask)).unwrap();
    report.depth(&depth).figure("mean error", "0.1°");
    report.surface(&depth, None).unwrap();
    let html = report.to_html().unwrap();

    // nothing from outside: every URL is inline, no external script, a strict CSP
    assert!(urls(&html).iter().all(|u| u.starts_with("data:")));
    assert!(!html.contains("<script src"));
    assert!(html.contains("default-src 'none'"));
    assert!(html.contains("cap &lt;test&gt;"), "title is escaped");
    assert!(html.contains("<td>mean error</td><td>0.1°</td>"));
    // the import map carries three.js itself
    let i = html
        .find("\"three\":\"data:text/javascript;base64,")
        .unwrap();
    let start = i + "\"three\":\"data:text/javascript;base64,".len();
    let three = b64(&html[start..start + html[start..].find('"').unwrap()]);
    assert!(String::from_utf8_lossy(&three[..200]).contains("Three.js Authors"));

    // the normal map picture: centre faces the camera → (128,128,255); corners are background
    let nm = png(&html, 0);
    assert_eq!((nm.width(), nm.height()), (64, 48));
    let n = normals.get(24, 32);
    let expect = n.map(|x| ((x + 1.0) * 0.5 * 255.0).round() as u8);
    assert_eq!(nm.get_pixel(32, 24).0, expect);
    assert!(expect[2] >= 254);
    // top of the cap faces up (+y): green above 128
    assert!(nm.get_pixel(32, 8).0[1] > 200);
    assert_eq!(
        nm.get_pixel(0, 0).0,
        photostereo::report::raster::BACKGROUND
    );
}

#[test]
fn mesh_payload_holds_the_surface() {
    let depth = cap(50, 50, 22.0);
    let inside = depth.data.iter().filter(|z| z.is_finite()).count();
    let mut report = Report::new("mesh");
    report.surface(&depth, None).unwrap();
    let mesh = report.viewer_mesh().unwrap();
    // stride 1: one vertex per pixel, about two triangles per pixel
    assert!(mesh.triangles() > inside * 3 / 2 && mesh.triangles() < inside * 2);
    let html = report.to_html().unwrap();
    let json_start = html.find("id=\"ps-mesh\">").unwrap() + "id=\"ps-mesh\">".len();
    let json_end = json_start + html[json_start..].find("</script>").unwrap();
    let v: serde_json::Value = serde_json::from_str(&html[json_start..json_end]).unwrap();
    let pos = b64(v["positions"].as_str().unwrap());
    assert_eq!(pos.len(), inside * 12);
    let idx = b64(v["indices"].as_str().unwrap());
    assert_eq!(idx.len(), mesh.triangles() * 12);
    // the highest vertex is the cap's apex, z ≈ 22 (pixel centres miss the exact top)
    let zmax = pos
        .chunks(12)
        .map(|p| f32::from_le_bytes(p[8..12].try_into().unwrap()))
        .fold(f32::MIN, f32::max);
    assert!((zmax - 22.0).abs() < 0.05, "apex {zmax}");
    assert!(v["colors"].is_null());
}

#[test]
fn large_depth_maps_are_decimated_by_striding() {
    let depth = cap(900, 900, 440.0);
    let mut report = Report::new("big");
    report.surface(&depth, None).unwrap();
    let n = report.viewer_mesh().unwrap().triangles();
    assert!(n <= MAX_TRIANGLES && n > MAX_TRIANGLES / 3, "{n} triangles");
}

#[test]
fn maps_bigger_than_the_page_are_shrunk_and_the_caption_says_so() {
    let depth = cap(2100, 300, 140.0);
    let mut report = Report::new("wide");
    report.depth(&depth);
    let html = report.to_html().unwrap();
    let img = png(&html, 0);
    // 2100 px wide: box averages of 3 × 3 pixels, 700 × 100
    assert_eq!((img.width(), img.height()), (700, 100));
    assert!(
        html.contains("(shown at 700×100, box averages of the 2100×300 map)"),
        "caption"
    );
}

#[test]
fn bad_input_gets_clear_errors() {
    let depth = cap(20, 20, 8.0);
    let mut report = Report::new("bad");
    let wrong = Mask::full(10, 20);
    assert!(matches!(
        report.albedo(&depth, Some(&wrong)),
        Err(Error::SizeMismatch { .. })
    ));
    let err = report
        .png(Section::Interreflections, "plot", b"GIF89a".to_vec())
        .unwrap_err();
    assert!(err.to_string().contains("PNG"), "{err}");
    let empty = Image::filled(8, 8, f32::NAN);
    assert!(matches!(
        report.surface(&empty, None),
        Err(Error::EmptyMask { .. })
    ));
    let v = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let bad = MeshParts {
        vertices: &v,
        normals: &[],
        colors: Some(&[[1, 2, 3]]),
        faces: &[[0, 1, 2]],
    };
    assert!(report.mesh(bad).unwrap_err().to_string().contains("colour"));
    // nothing was added by the failed calls
    assert!(report.viewer_mesh().is_none());
}
