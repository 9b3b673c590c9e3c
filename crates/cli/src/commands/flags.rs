//! Flags generated from a stage's configuration struct (`#[command(flatten)]`) on top of
//! a configuration file: the file gives the base, and only the flags given on the
//! command line replace its values (a flag's default never overrides the file).

use clap::parser::ValueSource;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// `base` with every top-level field whose flag was given on the command line taken
/// from `flags` (the same struct as clap parsed it). Flag ids are the field names.
pub fn override_given<T>(base: &T, flags: &T, matches: &clap::ArgMatches) -> anyhow::Result<T>
where
    T: Serialize + DeserializeOwned,
{
    let mut merged = serde_json::to_value(base)?;
    let given = serde_json::to_value(flags)?;
    if let (Some(m), Some(g)) = (merged.as_object_mut(), given.as_object()) {
        for (key, value) in g {
            let on_command_line = matches.try_get_raw(key).ok().flatten().is_some()
                && matches.value_source(key) == Some(ValueSource::CommandLine);
            if on_command_line {
                m.insert(key.clone(), value.clone());
            }
        }
    }
    Ok(serde_json::from_value(merged)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Args, CommandFactory, FromArgMatches, Parser};
    use serde::Deserialize;

    #[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Args)]
    struct Settings {
        #[arg(long, default_value_t = 10)]
        iterations: u64,
        #[arg(long, default_value_t = 0)]
        seed: u64,
    }

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        settings: Settings,
    }

    fn merged(argv: &[&str]) -> Settings {
        let matches = Cli::command().get_matches_from(argv);
        let cli = Cli::from_arg_matches(&matches).unwrap();
        let file = Settings {
            iterations: 500,
            seed: 7,
        };
        override_given(&file, &cli.settings, &matches).unwrap()
    }

    #[test]
    fn only_given_flags_override_the_file() {
        assert_eq!(
            merged(&["x"]),
            Settings {
                iterations: 500,
                seed: 7
            }
        );
        assert_eq!(
            merged(&["x", "--seed", "3"]),
            Settings {
                iterations: 500,
                seed: 3
            }
        );
        // A flag given with its default value still overrides.
        assert_eq!(merged(&["x", "--iterations", "10"]).iterations, 10);
    }
}
