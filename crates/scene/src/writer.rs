use std::fmt::Write;

use raylume_geometry::{Vec3, Vec3A};

use crate::{LightShape, Scene, Shape};

fn v3(out: &mut String, v: Vec3A) {
    let _ = write!(out, "{} {} {}", v.x, v.y, v.z);
}

fn c3(out: &mut String, c: Vec3) {
    let _ = write!(out, "{} {} {}", c.x, c.y, c.z);
}

impl Scene {
    /// The scene as p3f text. Numbers are written in their shortest exact form, so parsing the text
    /// gives back an equal scene.
    pub fn to_p3f(&self) -> String {
        let mut text = String::new();
        let o = &mut text;
        if let Some(a) = self.accel_hint {
            let _ = writeln!(o, "accel {}", a as u32);
        }
        if let Some(s) = self.spp_hint {
            let _ = writeln!(o, "spp {s}");
        }
        if let Some((t0, t1)) = self.shutter {
            let _ = writeln!(o, "shutter {t0} {t1}");
        }
        o.push_str("bclr ");
        c3(o, self.background);
        o.push('\n');
        if let Some(env) = &self.env {
            let _ = writeln!(o, "env {env}");
        }
        let v = &self.view;
        o.push_str("v\nfrom ");
        v3(o, v.from);
        o.push_str("\nat ");
        v3(o, v.at);
        o.push_str("\nup ");
        v3(o, v.up);
        let _ = writeln!(o, "\nangle {}\nhither {}\nresolution {} {}", v.angle_deg, v.hither, v.width, v.height);
        let _ = writeln!(o, "aperture {}\nfocal {}", v.aperture, v.focal);
        for l in &self.lights {
            match l.shape {
                LightShape::Point | LightShape::Square(_) => o.push_str("l "),
                LightShape::Parallelogram { .. } => o.push_str("light quad "),
            }
            v3(o, l.position);
            o.push(' ');
            c3(o, l.color);
            match l.shape {
                LightShape::Point => {}
                LightShape::Square(size) => {
                    let _ = write!(o, " {size}");
                }
                LightShape::Parallelogram { ends, grid } => {
                    for e in ends {
                        o.push(' ');
                        v3(o, e);
                    }
                    let _ = write!(o, " {grid}");
                }
            }
            o.push('\n');
        }
        // Each material, then the objects that use it: the canonical order the parser and the
        // builder produce (objects in the order of their materials).
        for (index, m) in self.materials.iter().enumerate() {
            o.push_str("f ");
            c3(o, m.diffuse);
            let _ = write!(o, " {} ", m.kd);
            c3(o, m.specular);
            let _ = write!(o, " {} {} {} {}", m.ks, m.shine, m.transmittance, m.ior);
            if m.roughness > 0.0 {
                let _ = write!(o, " {}", m.roughness);
            }
            o.push('\n');
            for obj in self.objects.iter().filter(|obj| obj.material as usize == index) {
                write_shape(o, &obj.shape);
            }
        }
        text
    }
}

fn write_shape(o: &mut String, shape: &Shape) {
    match shape {
        Shape::Sphere { center, radius } => {
            o.push_str("s ");
            v3(o, *center);
            let _ = writeln!(o, " {radius}");
        }
        Shape::MovingSphere { center0, center1, radius, time0, time1 } => {
            o.push_str("sm ");
            v3(o, *center0);
            o.push(' ');
            v3(o, *center1);
            let _ = writeln!(o, " {radius} {time0} {time1}");
        }
        Shape::Box { min, max } => {
            o.push_str("box ");
            v3(o, *min);
            o.push(' ');
            v3(o, *max);
            o.push('\n');
        }
        Shape::Polygon(vs) => {
            let _ = writeln!(o, "p {}", vs.len());
            for p in vs {
                v3(o, *p);
                o.push('\n');
            }
        }
        Shape::Patch(vs) => {
            let _ = writeln!(o, "pp {}", vs.len());
            for (p, n) in vs {
                v3(o, *p);
                o.push(' ');
                v3(o, *n);
                o.push('\n');
            }
        }
        Shape::Plane(ps) => {
            o.push_str("pl");
            for p in ps {
                o.push(' ');
                v3(o, *p);
            }
            o.push('\n');
        }
        Shape::Cone { base, base_radius, apex, apex_radius } => {
            o.push_str("c ");
            v3(o, *base);
            let _ = write!(o, " {base_radius} ");
            v3(o, *apex);
            let _ = writeln!(o, " {apex_radius}");
        }
        // p3f's `mesh` has no normals: a smooth mesh is written as one patch per triangle.
        Shape::Mesh { vertices, triangles, normals } if !normals.is_empty() => {
            for (t, n) in triangles.iter().zip(normals) {
                o.push_str("pp 3\n");
                for (&i, &n) in t.iter().zip(n) {
                    v3(o, vertices[i as usize]);
                    o.push(' ');
                    v3(o, n);
                    o.push('\n');
                }
            }
        }
        Shape::Mesh { vertices, triangles, .. } => {
            let _ = writeln!(o, "mesh {} {}", vertices.len(), triangles.len());
            for p in vertices {
                v3(o, *p);
                o.push('\n');
            }
            for t in triangles {
                let _ = writeln!(o, "{} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
            }
        }
    }
}
