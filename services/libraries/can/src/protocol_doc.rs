//! The tables of `PROTOCOL.md` rendered from the protocol's own layout tables, so the document
//! cannot drift from the code (a test compares them).

use crate::protocol::*;

/// Renders the identifier table of PROTOCOL.md from the layout tables (kept in sync by a test).
pub fn id_table(ids: &IdMap) -> String {
    let mut out =
        String::from("| ID (base 0x100) | offset | device | message | frame | DLC | direction |\n");
    out.push_str("|---|---|---|---|---|---|---|\n");
    for kind in MessageKind::ALL {
        for part in 0..kind.parts() {
            let Some(id) = ids.id(kind, part) else {
                continue;
            };
            let dir = match kind.direction() {
                Direction::FromNode => "node → computer",
                Direction::ToNode => "computer → node",
            };
            out.push_str(&format!(
                "| 0x{id:03X} | +0x{:02X} | {} | {} | {}/{} | {} | {dir} |\n",
                id - ids.base(),
                kind.device().name(),
                kind.name(),
                part + 1,
                kind.parts(),
                kind.dlc(part).unwrap_or(0),
            ));
        }
    }
    out
}

/// Renders the scaling table of PROTOCOL.md (kept in sync by a test).
pub fn scaling_table(limits: &Limits) -> String {
    let mut out = String::from(
        "| quantity | bits | LSB | wire span ± | default range ± | worst-case quantisation |\n",
    );
    out.push_str("|---|---|---|---|---|---|\n");
    for q in Quantity::ALL {
        let span = f64::from(q.raw_max()) * q.lsb_unit();
        let range = match limits.range(q) {
            Some(r) => format!("{} {}", fmt_num(r / q.unit_si()), q.unit()),
            None => "one turn (wraps)".to_string(),
        };
        let span = if q.wraps() {
            "180 °".to_string()
        } else {
            format!("{} {}", fmt_num(span), q.unit())
        };
        out.push_str(&format!(
            "| {} | {} | {} {} | {span} | {range} | {} {} |\n",
            q.name(),
            q.bits(),
            fmt_num(q.lsb_unit()),
            q.unit(),
            fmt_num(q.lsb_unit() / 2.0),
            q.unit(),
        ));
    }
    out
}

fn fmt_num(x: f64) -> String {
    // Plain notation for "round" numbers, otherwise scientific with up to 7 significant digits.
    let plain = format!("{}", (x * 1e9).round() / 1e9);
    let t = format!("{x:.6e}");
    let (m, e) = t.split_once('e').unwrap_or((&t, "0"));
    let m = m.trim_end_matches('0').trim_end_matches('.');
    if x != 0.0 && (x.abs() < 1e-3 || plain.len() > 12) {
        format!("{m}e{e}")
    } else {
        plain
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cargo test -p testbed-can --lib protocol_doc::tests::print_tables -- --ignored --nocapture` prints the tables
    /// for PROTOCOL.md.
    #[test]
    #[ignore]
    fn print_tables() {
        println!("{}", id_table(&IdMap::default()));
        println!("{}", scaling_table(&Limits::default()));
    }

    #[test]
    fn protocol_md_tables_match_the_code() {
        let doc = include_str!("../PROTOCOL.md");
        let ids = id_table(&IdMap::default());
        assert!(
            doc.contains(&ids),
            "PROTOCOL.md ID table is out of date; expected:\n{ids}"
        );
        let scales = scaling_table(&Limits::default());
        assert!(
            doc.contains(&scales),
            "PROTOCOL.md scaling table is out of date; expected:\n{scales}"
        );
    }
}
