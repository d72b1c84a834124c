//! Embedding raylume: build a scene in code, render it, write a PNG.
//!
//! `cargo run --release --example embed -- out.png`

use raylume::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = SceneBuilder::new()
        .camera(Vec3A::new(0.0, 1.5, 6.0), Vec3A::new(0.0, 0.5, 0.0), Vec3A::Y, 40.0, 320, 240)
        .background(Vec3::new(0.5, 0.7, 0.9))
        .light(Vec3A::new(4.0, 6.0, 5.0), Vec3::ONE)
        .material(Phong { diffuse: Vec3::new(0.8, 0.8, 0.75), kd: 0.9, ..Phong::default() })
        .plane([Vec3A::ZERO, Vec3A::new(0.0, 0.0, -1.0), Vec3A::new(-1.0, 0.0, 0.0)])
        .material(Phong {
            diffuse: Vec3::new(0.9, 0.2, 0.1),
            kd: 0.8,
            specular: Vec3::ONE,
            ks: 0.3,
            shine: 50.0,
            ..Phong::default()
        })
        .sphere(Vec3A::new(0.0, 1.0, 0.0), 1.0)
        .build()?;
    let options = RenderOptions { spp: Some(4), ..RenderOptions::default() };
    let out = scene.render(&options, &())?;
    let path = std::env::args().nth(1).unwrap_or_else(|| "embed.png".to_owned());
    out.film.write(&path)?;
    println!("wrote {path}: {} rays in {:.3} s", out.stats.total(), out.render_seconds);
    Ok(())
}
