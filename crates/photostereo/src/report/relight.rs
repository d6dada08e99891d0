//! The relighting view: the normals and albedo shaded under a light the reader drags over
//! the picture, I = ρ · max(0, n · l) (Lambertian), the way heritage users inspect an object
//! in RTI viewers. The maps are embedded at most [`MAX_SIDE`] pixels a side (box averages);
//! the page's script reports what it drew in `<html data-relight>` (`drawn`),
//! `data-relight-light` (l) and `data-relight-mean` (mean grey level inside the mask).

use base64::Engine as _;

use crate::error::Result;
use crate::image::{GrayImage, Mask, NormalMap};
use crate::picture as raster;

/// Largest side of the relighting maps embedded in the page.
pub const MAX_SIDE: usize = 512;
/// The light the view starts with: up and to the right, 34° from the view axis.
pub const START_LIGHT: [f32; 2] = [0.4, 0.4];

/// The maps of the relighting view, quantised for the page.
#[derive(Clone, Debug, PartialEq)]
pub struct RelightMaps {
    /// Width and height (pixels of the embedded maps).
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Unit normals × 127, rounded (x, y, z per pixel).
    pub normals: Vec<i8>,
    /// Albedo as grey levels (its 99th percentile → 255; 204 where there is no albedo).
    pub albedo: Vec<u8>,
    /// 1 inside the mask, 0 outside.
    pub mask: Vec<u8>,
}

impl RelightMaps {
    /// The maps of `normals` (and `albedo`) inside `mask`, box-averaged by the smallest
    /// integer factor that brings them to at most [`MAX_SIDE`] pixels a side.
    pub fn new(
        normals: &NormalMap,
        albedo: Option<&GrayImage>,
        mask: Option<&Mask>,
    ) -> Result<Self> {
        let (w, h) = (normals.width, normals.height);
        if let Some(m) = mask {
            m.check_size(w, h, "mask of the relighting view")?;
        }
        if let Some(a) = albedo {
            Mask::full(a.width, a.height).check_size(w, h, "albedo of the relighting view")?;
        }
        let step = w.max(h).div_ceil(MAX_SIDE).max(1);
        let (sw, sh) = (w.div_ceil(step), h.div_ceil(step));
        let white = albedo
            .map_or(1.0, |a| raster::albedo_white(a, mask))
            .max(1e-6);
        let mut out = RelightMaps {
            width: sw,
            height: sh,
            normals: Vec::with_capacity(sw * sh * 3),
            albedo: Vec::with_capacity(sw * sh),
            mask: Vec::with_capacity(sw * sh),
        };
        for br in 0..sh {
            for bc in 0..sw {
                let (n, a, inside) = block(normals, albedo, mask, (br * step, bc * step), step);
                out.normals
                    .extend(n.map(|v| (v * 127.0).round().clamp(-127.0, 127.0) as i8));
                let grey = albedo.map_or(204.0, |_| 255.0 * a / white);
                out.albedo.push(grey.round().clamp(0.0, 255.0) as u8);
                out.mask.push(u8::from(inside));
            }
        }
        Ok(out)
    }

    /// The page's JSON block: sizes, the start light and the maps in base64.
    pub(crate) fn payload_json(&self) -> String {
        let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
        let normals: Vec<u8> = self.normals.iter().map(|&v| v as u8).collect();
        format!(
            "{{\"w\":{},\"h\":{},\"light\":[{},{}],\"normals\":\"{}\",\"albedo\":\"{}\",\"mask\":\"{}\"}}",
            self.width,
            self.height,
            START_LIGHT[0],
            START_LIGHT[1],
            b64(&normals),
            b64(&self.albedo),
            b64(&self.mask)
        )
    }
}

/// The mean unit normal, mean albedo and inside flag (at least half the block inside) of
/// the `step`² block at `origin`.
fn block(
    normals: &NormalMap,
    albedo: Option<&GrayImage>,
    mask: Option<&Mask>,
    origin: (usize, usize),
    step: usize,
) -> ([f32; 3], f32, bool) {
    let (mut sum, mut a, mut inside, mut total) = ([0.0f32; 3], 0.0f32, 0usize, 0usize);
    for r in origin.0..(origin.0 + step).min(normals.height) {
        for c in origin.1..(origin.1 + step).min(normals.width) {
            total += 1;
            let n = *normals.get(r, c);
            let valid = mask.is_none_or(|m| *m.get(r, c))
                && n.iter().all(|v| v.is_finite())
                && n != [0.0; 3];
            if valid {
                inside += 1;
                sum = [sum[0] + n[0], sum[1] + n[1], sum[2] + n[2]];
                a += albedo.map_or(0.0, |al| al.get(r, c).max(0.0));
            }
        }
    }
    let len = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    if inside == 0 || 2 * inside < total || len == 0.0 {
        return ([0.0; 3], 0.0, false);
    }
    (
        [sum[0] / len, sum[1] / len, sum[2] / len],
        a / inside as f32,
        true,
    )
}

/// The view's script (plain, not a module: it needs nothing but a 2-D canvas).
pub(crate) const RELIGHT_JS: &str = r#"(function(){
var root=document.documentElement,el=document.getElementById('ps-relight-data');
if(!el){root.dataset.relight='none';return;}
var d=JSON.parse(el.textContent);
function b(s){var t=atob(s),o=new Uint8Array(t.length);for(var i=0;i<t.length;i++)o[i]=t.charCodeAt(i);return o;}
var n=new Int8Array(b(d.normals).buffer),a=b(d.albedo),m=b(d.mask);
var c=document.getElementById('ps-relight');c.width=d.w;c.height=d.h;
var ctx=c.getContext('2d'),img=ctx.createImageData(d.w,d.h),p=img.data;
function draw(lx,ly){var r=Math.hypot(lx,ly);if(r>0.999){lx*=0.999/r;ly*=0.999/r;}
var lz=Math.sqrt(Math.max(0,1-lx*lx-ly*ly)),sum=0,cnt=0;
for(var i=0;i<d.w*d.h;i++){var o=4*i;p[o+3]=255;
if(!m[i]){p[o]=27;p[o+1]=30;p[o+2]=36;continue;}
var s=(n[3*i]*lx+n[3*i+1]*ly+n[3*i+2]*lz)/127,v=Math.round(a[i]*Math.max(0,s));
p[o]=v;p[o+1]=v;p[o+2]=v;sum+=v;cnt++;}
ctx.putImageData(img,0,0);
root.dataset.relightLight=lx.toFixed(3)+','+ly.toFixed(3)+','+lz.toFixed(3);
root.dataset.relightMean=cnt?(sum/cnt).toFixed(2):'0';root.dataset.relight='drawn';}
function at(e){var q=c.getBoundingClientRect();
draw(2*(e.clientX-q.left)/q.width-1,1-2*(e.clientY-q.top)/q.height);}
var down=false;
c.addEventListener('pointerdown',function(e){down=true;at(e);});
window.addEventListener('pointerup',function(){down=false;});
c.addEventListener('pointermove',function(e){if(down)at(e);});
draw(d.light[0],d.light[1]);})();"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    #[test]
    fn big_maps_are_averaged_down_and_masked_blocks_left_out() {
        let n = Image::filled(1030, 8, [0.0f32, 0.6, 0.8]);
        let mut m = Mask::full(1030, 8);
        for r in 0..8 {
            for c in 0..3 {
                *m.get_mut(r, c) = false;
            }
        }
        let maps = RelightMaps::new(&n, None, Some(&m)).unwrap();
        // 1030 px at factor 3 -> 344 wide
        assert_eq!((maps.width, maps.height), (344, 3));
        assert_eq!(maps.mask[0], 0);
        assert_eq!(maps.mask[1], 1);
        assert_eq!(&maps.normals[3..6], &[0, 76, 102]);
        assert!(maps.payload_json().starts_with("{\"w\":344,\"h\":3,"));
    }

    #[test]
    fn empty_and_mismatched_inputs_are_handled() {
        let n: NormalMap = Image::filled(0, 0, [0.0; 3]);
        assert_eq!(RelightMaps::new(&n, None, None).unwrap().width, 0);
        let n = Image::filled(4, 4, [0.0f32, 0.0, 1.0]);
        assert!(RelightMaps::new(&n, None, Some(&Mask::full(3, 4))).is_err());
        assert!(RelightMaps::new(&n, Some(&Image::filled(2, 2, 1.0)), None).is_err());
    }
}
