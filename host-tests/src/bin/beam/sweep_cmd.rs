pub fn run(_a: &SweepArgs) -> Result<(), String> {
    Err("todo".into())
}
#[derive(clap::Args)]
pub struct SweepArgs {}
