//! Prints the knowledge-base passages BM25 ranks highest for a query:
//! `cargo run -p avacraft-ava --example kb_search -- "stalker blink" [K]`.

use avacraft_ava::{Bm25, KnowledgeBase, Retriever};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let query = args.next().ok_or("usage: kb_search QUERY [K]")?;
    let k = args.next().map(|s| s.parse::<usize>()).transpose()?.unwrap_or(3);
    let kb = KnowledgeBase::builtin()?;
    for hit in Bm25::new(&kb).search(&query, k) {
        println!("[{:.2}] {}\n  {}\n", hit.score, hit.passage.title, hit.passage.text);
    }
    Ok(())
}
