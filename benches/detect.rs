//! Each edge detector on a 1280×720 G-buffer with 4 samples per pixel: `detect/<detector>/1280x720x4`; and the
//! shading truth from the per-sample reference radiance (computed once, outside the loop):
//! `detect/shading-truth/1280x720x4`.
//! The G-buffer is ray-cast once, outside the timed loop, from a few analytic surfaces (floor, back wall, a tilted
//! panel in front, a tessellated sphere) so every detector has silhouettes, creases and triangle edges to find.

#[path = "../tests/support/detect.rs"]
mod support;

use criterion::{criterion_group, criterion_main, Criterion};
use gbuf::detect::{detect, Detector, DetectorConfig};
use gbuf::measure::edges::{shading_truth, DEFAULT_SHADING_TOLERANCE};
use glam::Vec3;
use std::hint::black_box;
use support::{render, Shape, Surface};

fn scene(w: u32, h: u32, samples: u32) -> gbuf::GBuffer {
    fn tri(p: Vec3) -> u32 {
        let (u, v) = (p.x * 8.0 + 500.0, p.y * 8.0 + 500.0);
        (u as u32) * 2000 + (v as u32) * 2 + u32::from(u.fract() + v.fract() > 1.0)
    }
    let a = 35f32.to_radians();
    let surfaces = [
        Surface {
            prim: Some(tri),
            ..Surface::new(Shape::Plane { normal: Vec3::Y, point: Vec3::new(0.0, -1.5, 0.0) }, 1)
        },
        Surface {
            prim: Some(tri),
            ..Surface::new(Shape::Plane { normal: Vec3::Z, point: Vec3::new(0.0, 0.0, -30.0) }, 2)
        },
        Surface {
            keep: Some(|p| p.x.abs() < 1.2 && p.y.abs() < 0.9),
            prim: Some(tri),
            ..Surface::new(
                Shape::Plane { normal: Vec3::new(a.sin(), 0.0, a.cos()), point: Vec3::new(-1.5, 0.0, -6.0) },
                3,
            )
        },
        Surface {
            prim: Some(tri),
            ..Surface::new(Shape::Sphere { center: Vec3::new(1.8, -0.3, -8.0), radius: 1.2 }, 4)
        },
    ];
    render(w, h, samples, &surfaces)
}

fn bench(c: &mut Criterion) {
    let (w, h, s) = (1280, 720, 4);
    let gb = scene(w, h, s);
    let cfg = DetectorConfig::default();
    let mut group = c.benchmark_group("detect");
    group.sample_size(10);
    for d in Detector::ALL {
        group.bench_function(format!("{}/{w}x{h}x{s}", d.name()), |b| {
            b.iter(|| detect(black_box(&gb), d, black_box(&cfg)).unwrap())
        });
    }
    let lights = [
        gbuf::Light::point(Vec3::new(-1.0, 0.5, -5.0), Vec3::new(1.0, 0.8, 0.6), 8.0, 12.0),
        gbuf::Light::point(Vec3::new(2.0, 1.0, -7.0), Vec3::new(0.6, 0.8, 1.0), 8.0, 12.0),
    ];
    let radiance = gbuf::resolve::reference_per_sample(&gb, &lights, &Default::default()).unwrap();
    group.bench_function(format!("shading-truth/{w}x{h}x{s}"), |b| {
        b.iter(|| shading_truth(black_box(&gb), black_box(&radiance), DEFAULT_SHADING_TOLERANCE))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
