use photostereo::io;
#[test]
fn outline_slant() {
    for o in ["bear", "harvest"] {
        let d = std::path::Path::new("../../../shared/data/real/diligent_normals").join(o);
        let d = if d.exists() {
            d
        } else {
            std::path::Path::new("../../shared/data/real/diligent_normals").join(o)
        };
        let n = io::read_normals_png(&d.join("normal_map.png")).unwrap();
        let m = io::read_mask(&d.join("mask.png")).unwrap();
        let w = m.width;
        let mut s = vec![];
        for i in 0..m.len() {
            if !m.data[i] {
                continue;
            }
            let (r, c) = (i / w, i % w);
            let out = [(0i64, 1i64), (0, -1), (1, 0), (-1, 0)]
                .iter()
                .any(|&(dr, dc)| {
                    let (rr, cc) = (r as i64 + dr, c as i64 + dc);
                    rr >= 0
                        && cc >= 0
                        && (rr as usize) < m.height
                        && (cc as usize) < w
                        && !m.data[rr as usize * w + cc as usize]
                });
            if out {
                s.push(n.data[i][2]);
            }
        }
        s.sort_by(f32::total_cmp);
        let q = |f: f64| s[((s.len() - 1) as f64 * f) as usize];
        println!(
            "{o}: {} outline px, n_z quantiles 10% {:.3} 25% {:.3} 50% {:.3} 75% {:.3} 90% {:.3}",
            s.len(),
            q(0.1),
            q(0.25),
            q(0.5),
            q(0.75),
            q(0.9)
        );
    }
}
