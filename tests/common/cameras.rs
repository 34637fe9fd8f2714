//! The `camera:` blocks that open a lens (on `cornell`) and a shutter (on the moving `motion`
//! scene) without a Defocus or Motion node, with the closed block each is compared with (issue 34 §2).

/// A camera the nodes sample without a Defocus or Motion node: its scene, size, and the
/// camera block that opens it and the one that does not.
pub struct OpenCamera {
    pub what: &'static str,
    pub scene: &'static str,
    pub size: (u32, u32),
    pub open: &'static str,
    pub closed: &'static str,
    /// How `wedge graph` says the image is seen.
    pub view: &'static str,
}

pub const CAMERAS: [OpenCamera; 2] = [
    OpenCamera {
        what: "lens",
        scene: "cornell",
        size: (32, 24),
        open: "position: (0.0, 1.0, 3.5), look_at: (0.0, 1.0, 0.0), vfov_deg: 40.0, aperture_radius: 0.15, focus_distance: Some(2.0)",
        closed: "position: (0.0, 1.0, 3.5), look_at: (0.0, 1.0, 0.0), vfov_deg: 40.0, aperture_radius: 0.0",
        view: ", through the lens",
    },
    OpenCamera {
        what: "shutter",
        scene: "motion",
        size: (96, 72),
        open: "position: (0, 2.2, 4.2), look_at: (0, 0.35, 0), vfov_deg: 45, shutter: Some((0.0, 1.0))",
        closed: "position: (0, 2.2, 4.2), look_at: (0, 0.35, 0), vfov_deg: 45, shutter: Some((0.5, 0.5))",
        view: ", over the shutter",
    },
];
