//! The example `render_in_rust` runs: it writes a PNG of the sphere.

#[allow(dead_code)] // its `main` is the example's, not the test's
#[path = "../examples/render_in_rust.rs"]
mod example;

#[test]
fn render_in_rust_example_writes_the_sphere() {
    let dir = std::env::temp_dir().join(format!("phongrt-render-example-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sphere.png");
    let out = example::run(&path).unwrap();
    let png = image::open(&path).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (320, 240));
    // The sphere covers the middle of the frame and not the corner.
    let (centre, corner) = (png.get_pixel(160, 120), png.get_pixel(0, 0));
    assert_ne!(centre, corner, "the centre shows the sphere, not the background");
    assert_eq!(out.rays.primary, 320 * 240 * 4);
    std::fs::remove_dir_all(&dir).unwrap();
}
