//! Arbitrary bytes into the YAML loader and the checkpoint decoder: no panic, no hang, no
//! allocation blow-up. A seeded mutation fuzzer (bounded: a few seconds), so CI runs the
//! same cases every time; `SOFTGRAIN_FUZZ_CASES` raises the count for a longer search.

mod common;

use softgrain::config;
use softgrain::pipeline::{codec, store};
use softgrain::rng::Rng;
use softgrain::stages::StageState;

fn cases() -> usize {
    std::env::var("SOFTGRAIN_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000)
}

/// Flips, inserts, deletes or duplicates a few bytes, or truncates.
fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        if b.is_empty() {
            b.push(rng.next_u64() as u8);
            continue;
        }
        let k = rng.below(b.len());
        match rng.below(5) {
            0 => b[k] ^= 1 << rng.below(8),
            1 => b.insert(k, rng.next_u64() as u8),
            2 => {
                b.remove(k);
            }
            3 => {
                let end = (k + 1 + rng.below(16)).min(b.len());
                let chunk = b[k..end].to_vec();
                b.splice(k..k, chunk);
            }
            _ => b.truncate(k),
        }
    }
    b
}

#[test]
fn the_yaml_loader_survives_mutated_pipelines() {
    let dir = common::temp_dir("fuzz-yaml");
    let seeds: Vec<Vec<u8>> = ["quick", "incline", "single-grain-bpm", "single-grain-mpm"]
        .iter()
        .map(|n| std::fs::read(format!("pipelines/{n}.yaml")).unwrap())
        .collect();
    let mut rng = Rng::new(2026);
    let file = dir.join("f.yaml");
    let (mut ok, mut bad) = (0, 0);
    for k in 0..cases() {
        let bytes = mutate(&seeds[k % seeds.len()], &mut rng);
        std::fs::write(&file, &bytes).unwrap();
        match config::load(&file, &[]) {
            Ok(_) => ok += 1,
            Err(e) => {
                assert!(
                    e.to_string().starts_with(file.to_str().unwrap()),
                    "message must name the file: {e}"
                );
                bad += 1;
            }
        }
    }
    assert!(
        ok > 0 && bad > 0,
        "the mutations should hit both sides ({ok} ok, {bad} rejected)"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_checkpoint_decoder_survives_mutated_checkpoints() {
    // a real checkpoint: a small deposit
    let dir = common::temp_dir("fuzz-ckpt");
    let yaml = common::write(
        &dir,
        "d.yaml",
        "name: d\nprepare:\n  grains: 10\n  diameter: [1.4e-3, 2.4e-3]\noutput:\n  vtk: false\n",
    );
    let o = common::softgrain(&[
        "pipeline",
        "run",
        yaml.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success());
    let good = std::fs::read(&common::checkpoints(&dir.join("d"))[0]).unwrap();
    let payload = store::verify(&good).unwrap().to_vec();
    assert!(codec::decode::<StageState>(&payload).is_ok());
    let mut rng = Rng::new(7);
    for _ in 0..cases() {
        // whole files: the header and hash must reject every mutation
        let bytes = mutate(&good, &mut rng);
        if bytes != good {
            assert!(store::verify(&bytes).is_err());
        }
        // payloads past the hash (as if a mutation kept it): decode may fail, never panic
        let p = mutate(&payload, &mut rng);
        let _ = codec::decode::<StageState>(&p);
        // raw noise
        let noise: Vec<u8> = (0..rng.below(256)).map(|_| rng.next_u64() as u8).collect();
        let _ = codec::decode::<StageState>(&noise);
        assert!(store::verify(&noise).is_err());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
