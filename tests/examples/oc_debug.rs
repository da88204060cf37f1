use workspace_tests::operating::*;
use sins_model::candidates::Candidate;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let class = Class::ALL[args[1].parse::<usize>().unwrap()];
    let term = Candidate::from_id(&args[2]).unwrap();
    let k: f64 = args[3].parse().unwrap();
    let seed: u64 = args[4].parse().unwrap();
    let (values, z) = sized_values(class, term, k);
    println!("z_ref {z} values {values:?}");
    let o = run(class, seed, &values, true);
    println!("{o:#?}");
}
