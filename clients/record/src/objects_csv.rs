//! `objects.csv`: every object's state per published step, one row each. The one writer of this
//! file: `splatphys run` (both modes) and `splatphys-record export-objects` use it.
//!
//! Columns: `step,time_s,object,name,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg,fx_n,fy_n,fz_n`:
//! `object` is the object id, `name` its scene name (empty when unknown), positions and
//! velocities are the COM's in world metres and m/s, `f*_n` the contact force on a solid object
//! over the step (N; zero for deformable objects), at the wire's f32 precision. Fields are quoted as RFC 4180 asks
//! (only names can need it).

use std::io::Write;

use splatphys_ipc::wire::ObjectState;

/// The header line, without the line break.
pub const HEADER: &str =
    "step,time_s,object,name,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,mass_kg,fx_n,fy_n,fz_n";

/// Writes `objects.csv` rows to `W`.
#[derive(Debug)]
pub struct ObjectsCsv<W: Write> {
    out: W,
    names: Vec<String>,
    rows: u64,
}

impl<W: Write> ObjectsCsv<W> {
    /// Writes the header; `names[id]` names object `id` (missing entries are left empty).
    ///
    /// # Errors
    /// I/O errors of `out`.
    pub fn new(mut out: W, names: Vec<String>) -> std::io::Result<Self> {
        writeln!(out, "{HEADER}")?;
        Ok(Self {
            out,
            names,
            rows: 0,
        })
    }

    /// Writes one row per object of the frame at `step` / `time_s` (seconds).
    ///
    /// # Errors
    /// I/O errors of `out`.
    pub fn write_frame(
        &mut self,
        step: u64,
        time_s: f64,
        objects: &[ObjectState],
    ) -> std::io::Result<()> {
        for o in objects {
            let name = self.names.get(o.id as usize).map_or("", String::as_str);
            let (p, v, f) = (o.position_m, o.velocity_m_s, o.contact_force_n);
            writeln!(
                self.out,
                "{step},{time_s},{},{},{},{},{},{},{},{},{},{},{},{}",
                o.id,
                quoted(name),
                p[0],
                p[1],
                p[2],
                v[0],
                v[1],
                v[2],
                o.mass_kg,
                f[0],
                f[1],
                f[2]
            )?;
            self.rows += 1;
        }
        Ok(())
    }

    /// Rows written so far (header excluded).
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes and returns the writer.
    ///
    /// # Errors
    /// I/O errors of the flush.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// `field` as an RFC 4180 field: quoted, with inner quotes doubled, when it holds a comma, a
/// quote or a line break.
fn quoted(field: &str) -> std::borrow::Cow<'_, str> {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\"")).into()
    } else {
        field.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(id: u32, x: f32) -> ObjectState {
        ObjectState {
            id,
            position_m: [x, 0.0, 1.0],
            mass_kg: 2.0,
            contact_force_n: [0.0, 0.0, x * 10.0],
            ..Default::default()
        }
    }

    #[test]
    fn rows_carry_id_and_name_and_quote_names_that_need_it() {
        let names = vec!["ball".to_string(), "say \"hi\", box".to_string()];
        let mut w = ObjectsCsv::new(Vec::new(), names).unwrap();
        w.write_frame(3, 0.05, &[state(0, 0.5), state(1, -1.0), state(2, 0.0)])
            .unwrap();
        assert_eq!(w.rows(), 3);
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], HEADER);
        assert_eq!(lines[1], "3,0.05,0,ball,0.5,0,1,0,0,0,2,0,0,5");
        assert_eq!(
            lines[2],
            "3,0.05,1,\"say \"\"hi\"\", box\",-1,0,1,0,0,0,2,0,0,-10"
        );
        assert_eq!(lines[3], "3,0.05,2,,0,0,1,0,0,0,2,0,0,0");
    }
}
