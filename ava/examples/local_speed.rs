//! How fast the local back end runs SmolLM2-135M-Instruct (Q4_1) here: prompt tokens read and
//! answer tokens generated per second, free and constrained by the decision schema.
//!
//! `cargo run --release -p avacraft-ava --features local --example local_speed [-- THREADS [ROUNDS]]`

use avacraft_ava::llm::{ChatModel, ChatRequest, Local, LocalConfig, Message, Role, Sampling, Stage, find_smollm2};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let threads: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(0);
    let rounds: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(3);
    let path = find_smollm2()?;
    let t = Instant::now();
    let mut m = Local::new(LocalConfig { n_threads: threads, ..LocalConfig::new(&path) })?;
    println!("{} loaded in {:.2} s ({} threads, n_ctx {})", path.display(), t.elapsed().as_secs_f64(), threads, m.n_ctx());
    // A decision-sized prompt: about 800 tokens, like AVA's without images.
    let mut user = String::from(
        "Your units:\n- 1 Marine at cell [2, 4], health 45/45\n- 2 Marine at cell [2, 5], health 45/45\n- 3 Marine at cell [2, 6], health 45/45\nEnemies in sight:\n- 4 Marine at cell [8, 4], health 45/45\n- 5 Marine at cell [8, 5], health 45/45\n- 6 Marine at cell [8, 6], health 45/45\nUnit knowledge:\n",
    );
    for _ in 0..12 {
        user.push_str("- Marine: a ranged infantry unit of the Terrans with 45 health, range 5 and 6 damage a shot every 0.61 s; Stimpack trades 10 health for 50% more attack speed.\n");
    }
    user.push_str("Give one action per unit of yours (1, 2, 3). Answer as JSON: {\"reasoning\": \"<one sentence>\", \"actions\": [...]}");
    let req = |schema: bool, max_tokens| ChatRequest {
        stage: Stage::Decision,
        messages: vec![Message::text(Role::System, "You command units in a StarCraft II battle."), Message::text(Role::User, user.clone())],
        schema: schema
            .then(|| ("ava_decision".to_owned(), avacraft_ava::decision::schema(&ids(&[1, 2, 3]), &ids(&[4, 5, 6]), &["stimpack"]))),
        sampling: Sampling { temperature: 0.7, top_p: 0.95, max_tokens },
    };
    for (label, schema) in [("free text", false), ("decision schema", true)] {
        let before = m.stats();
        for _ in 0..rounds {
            let r = m.complete(&req(schema, 128))?;
            let u = r.usage.unwrap_or_default();
            println!(
                "  {label}: {} prompt + {} answer tokens in {:.0} ms ({})",
                u.prompt_tokens,
                u.completion_tokens,
                r.latency_ms,
                r.finish.unwrap_or_default()
            );
        }
        let s = m.stats();
        let (pt, pm) = (s.prompt_tokens - before.prompt_tokens, s.prompt_ms - before.prompt_ms);
        let (ct, cm) = (s.completion_tokens - before.completion_tokens, s.generate_ms - before.generate_ms);
        println!("{label}: prompt {:.0} tokens/s, answer {:.1} tokens/s", pt as f64 * 1000.0 / pm, ct as f64 * 1000.0 / cm);
    }
    Ok(())
}

fn ids(tags: &[u32]) -> Vec<avacraft_engine::UnitId> {
    tags.iter().filter_map(|&t| avacraft_engine::UnitId::try_from(t).ok()).collect()
}
