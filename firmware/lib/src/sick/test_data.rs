//! Telegrams shared by the unit tests of the SICK modules: the examples of the protocol
//! notes §11 and a hex helper.

/// Parses a hex string with spaces (`"02 00 01"`).
pub(crate) fn hex(text: &str) -> Vec<u8> {
    text.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// Every complete example telegram of protocol notes §11.
pub(crate) const EXAMPLE_TELEGRAMS: &[&str] = &[
    "02 00 01 00 31 15 12",
    "02 00 01 00 3A 1E 12",
    "02 00 01 00 74 50 12",
    "02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5",
    "02 00 02 00 20 42 52 08",
    "02 00 02 00 20 41 51 08",
    "02 00 02 00 20 40 50 08",
    "02 00 02 00 20 48 58 08",
    "02 00 05 00 3B B4 00 64 00 97 49",
    "02 00 05 00 3B B4 00 32 00 3B 1F",
    "02 00 05 00 3B 64 00 19 00 E7 72",
    "02 00 05 00 3B 64 00 32 00 B1 59",
    "02 00 05 00 3B 64 00 64 00 1D 0F",
    "02 00 02 00 20 24 34 08",
    "02 00 02 00 20 25 35 08",
    "02 00 02 00 30 01 31 18",
    "02 00 01 00 10 34 12",
    "02 80 03 00 A0 00 10 16 0A",
    "02 80 02 00 92 10 7F 33",
    "02 80 02 00 91 10 79 30",
    "02 80 07 00 BB 01 B4 00 32 00 10 03 9D",
    "02 81 17 00 90 4C 4D 53 32 30 30 3B 33 30 31 30 36 33 3B 56 30 32 2E 30 36 20 13 64 5A",
    "02 80 0A 00 B0 03 40 E8 03 D0 07 FF 1F 10 16 B1",
];

/// The rows of `sick-real/public-example-telegrams.tsv` whose `crc_ok` column says `yes`, as
/// (name, bytes); `None` (after a skip notice) when the dataset is missing.
pub(crate) fn public_examples(test: &str) -> Option<Vec<(String, Vec<u8>)>> {
    let path = datasets::require("sick-real/public-example-telegrams.tsv", test)?;
    let text = std::fs::read_to_string(path).unwrap();
    Some(
        text.lines()
            .filter(|line| !line.starts_with('#') && !line.trim().is_empty())
            .filter_map(|line| {
                let cols: Vec<&str> = line.split('\t').collect();
                (cols[1] == "yes").then(|| (cols[0].to_string(), hex(cols[4])))
            })
            .collect(),
    )
}

/// The real 732-byte `B0h` telegram of `sick-real/dtu-usick-b0-361-mm.bin`.
pub(crate) fn real_b0(test: &str) -> Option<Vec<u8>> {
    let path = datasets::require("sick-real/dtu-usick-b0-361-mm.bin", test)?;
    Some(std::fs::read(path).unwrap())
}
