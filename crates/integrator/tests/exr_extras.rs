//! An EXR written with extras carries the per-pixel variance as channels and the render's attributes
//! in its header, as another reader (the `exr` crate) sees them.

use raylume_geometry::Vec3;
use raylume_integrator::{Extras, Film, MetaValue};

#[test]
fn variance_channels_and_attributes_reach_the_file() {
    let path = std::env::temp_dir().join(format!("raylume-exr-extras-{}.exr", std::process::id()));
    let film = Film::from_pixels(3, 2, (0..6).map(|i| Vec3::new(i as f32, 0.5, 0.25)).collect());
    let variance = Film::from_pixels(3, 2, (0..6).map(|i| Vec3::splat(i as f32 * 1e-3)).collect());
    let extras = Extras {
        variance: Some(&variance),
        attributes: vec![
            ("raylume.estimated_rmse".into(), MetaValue::Number(0.0125)),
            ("raylume.seed".into(), MetaValue::Text("42".into())),
        ],
        ..Extras::default()
    };
    film.write_with(&path, &extras).unwrap();

    use exr::prelude::*;
    let image = read().no_deep_data().largest_resolution_level().all_channels().all_layers().all_attributes();
    let image = image.from_file(&path).unwrap();
    let layer = &image.layer_data[0];
    let channel = |name: &str| {
        let key = Text::from(name);
        let c = layer.channel_data.list.iter().find(|c| c.name == key).unwrap();
        c.sample_data.values_as_f32().collect::<Vec<f32>>()
    };
    assert_eq!(channel("R"), [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    assert_eq!(channel("variance.G"), variance.pixels().iter().map(|p| p.y).collect::<Vec<_>>());
    let attribute = |name: &str| layer.attributes.other.get(&Text::from(name)).cloned();
    assert_eq!(attribute("raylume.estimated_rmse"), Some(AttributeValue::F64(0.0125)));
    assert_eq!(attribute("raylume.seed"), Some(AttributeValue::Text(Text::from("42"))));
    // Readers of RGB images see the image alone.
    assert_eq!(Film::read(&path).unwrap(), film);
    std::fs::remove_file(&path).unwrap();
}
