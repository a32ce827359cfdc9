//! Writing meshes as OBJ.

use std::io::Write;
use std::path::Path;

use super::Mesh;

/// Write a mesh as OBJ (positions, normals, `f v//vn`), 7 significant digits.
pub fn write_obj(mesh: &Mesh, path: &Path, header: &str) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for l in header.lines() {
        writeln!(f, "# {l}")?;
    }
    writeln!(f, "o {}", mesh.name)?;
    for p in &mesh.positions {
        writeln!(f, "v {:.7} {:.7} {:.7}", p.x, p.y, p.z)?;
    }
    for n in &mesh.normals {
        writeln!(f, "vn {:.7} {:.7} {:.7}", n.x, n.y, n.z)?;
    }
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(f, "f {a}//{a} {b}//{b} {c}//{c}")?;
    }
    f.flush()
}
