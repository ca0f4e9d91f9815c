//! The channels of a multi-channel head each with their own share of the
//! pulses, divergence and wavelength, checked against what those mean on
//! paper: a channel firing `n` of every `Σn` pulses gives that share of
//! the points; a wider beam beside a roof edge puts the share of a
//! Gaussian footprint beyond the edge on the roof (a second echo) where a
//! narrow one does not; a channel's echoes are as bright as the
//! material's reflectance at its wavelength (Eq. 2 is linear in it).

use lidarsim::Survey;
use lidarsim::output::PointRecord;
use lidarsim::sim::simulate_to_memory;

/// Flies the `[scanner]` keys `scanner` (nadir, 20 kHz) north along
/// `x = line_x` at 500 m over a ground of material `ground`, with the extra
/// scene `extra`.
fn fly(scanner: &str, line_x: f64, ground: &str, extra: &str) -> Vec<PointRecord> {
    let text = format!(
        r#"
seed = 5
[scanner]
prf_hz = 20000
scan_angle_deg = 0
{scanner}
[[flight_line]]
start_m = [{line_x}, -5.0, 500.0]
end_m = [{line_x}, 5.0, 500.0]
speed_mps = 50.0
[materials.ground]
{ground}
[[polygon]]
material = "ground"
class = "ground"
vertices_m = [[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]]
{extra}
"#
    );
    let s = Survey::from_toml(&text, None).unwrap_or_else(|e| panic!("{e}"));
    simulate_to_memory(&s, 2).unwrap()
}

/// Mean amplitude of the points of `channel`.
fn mean_amplitude(points: &[PointRecord], channel: u8) -> f64 {
    let a: Vec<f64> = points
        .iter()
        .filter(|p| p.channel == channel)
        .map(|p| p.amplitude)
        .collect();
    assert!(a.len() > 100, "channel {channel}: {} points", a.len());
    a.iter().sum::<f64>() / a.len() as f64
}

#[test]
fn each_channel_fires_its_share_of_the_pulses() {
    let points = fly(
        "subrays = 1\n[[scanner.channels]]\npulses_per_cycle = 3\n\
         [[scanner.channels]]\npulses_per_cycle = 1",
        0.0,
        "reflectance = 0.5",
        "",
    );
    // 0.2 s at 20 kHz, one echo per pulse.
    assert_eq!(points.len(), 4000);
    let first = points.iter().filter(|p| p.channel == 0).count();
    assert_eq!(first, 3000);
    assert!(points.iter().all(|p| p.channel < 2));
}

/// Nadir pulses whose axis meets the ground 0.25 m beside the edge of a
/// roof plate 1 m up. A Gaussian beam of full divergence γ has its 1/e²
/// radius `w = Rγ/2` and a standard deviation `w/2` across the edge: at
/// 2 mrad and 500 m that is 0.25 m, so `Q(1) = 15.9 %` of the energy falls
/// on the plate (a second echo, the pulse being 0.6 m long, for a receiver
/// that resolves what its waveform resolves); at 0.2 mrad the edge is ten
/// deviations away and nothing does.
#[test]
fn each_channel_spreads_its_own_divergence() {
    let plate = "[materials.plate]\nreflectance = 0.5\n[[polygon]]\nmaterial = \"plate\"\n\
                 class = \"roof\"\nvertices_m = [[-50, -50, 1], [0, -50, 1], [0, 50, 1], [-50, 50, 1]]\n";
    let points = fly(
        "subrays = 241\ndivergence_mrad = 0.2\necho_detection = \"waveform\"\n\
         [[scanner.channels]]\ndivergence_mrad = 2.0\n[[scanner.channels]]",
        0.25,
        "reflectance = 0.5",
        plate,
    );
    let (wide, narrow): (Vec<&PointRecord>, Vec<&PointRecord>) =
        points.iter().partition(|p| p.channel == 0);
    assert!(narrow.len() > 1000, "{}", narrow.len());
    assert!(
        narrow
            .iter()
            .all(|p| p.number_of_returns == 1 && p.classification == 2),
        "the narrow beam saw the plate"
    );
    assert!(wide.iter().all(|p| p.number_of_returns == 2));
    let amplitude = |class: u8| {
        let a: Vec<f64> = wide
            .iter()
            .filter(|p| p.classification == class)
            .map(|p| p.amplitude)
            .collect();
        a.iter().sum::<f64>() / a.len() as f64
    };
    // The plate's share over the ground's, the plate 1 m nearer (Eq. 2's
    // R⁻²).
    let q = 0.158_655;
    let want = q / (1.0 - q) * (500.0f64 / 499.0).powi(2);
    let got = amplitude(6) / amplitude(2);
    assert!((got / want - 1.0).abs() < 0.05, "{got} vs {want}");
}

/// Green vegetation is dark at 532 nm and bright at 1064 nm: each
/// channel's echoes take the reflectance of its own wavelength, the
/// spectrum interpolated linearly between its points (905 nm: 0.1 +
/// 0.4 · 373/532).
#[test]
fn each_channel_sees_the_reflectance_at_its_wavelength() {
    let points = fly(
        "subrays = 7\n[[scanner.channels]]\nwavelength_nm = 532\n\
         [[scanner.channels]]\nwavelength_nm = 905\n[[scanner.channels]]\nwavelength_nm = 1064",
        0.0,
        "reflectance_spectrum = [[532, 0.1], [1064, 0.5]]",
        "",
    );
    let [green, nir, ir] = [0, 1, 2].map(|c| mean_amplitude(&points, c));
    // Eq. 2 for a level Lambertian plane filling the beam: ρ (Rn/R)².
    let full = (1000.0f64 / 500.0).powi(2);
    for (got, rho) in [(green, 0.1), (nir, 0.1 + 0.4 * 373.0 / 532.0), (ir, 0.5)] {
        assert!(
            (got / (rho * full) - 1.0).abs() < 0.01,
            "{got} vs ρ = {rho}"
        );
    }
}
