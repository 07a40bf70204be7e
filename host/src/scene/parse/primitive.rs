//! Primitives: the shapes (a mesh with its OBJ file) and their material,
//! textures among it.

use super::names::{shown, suggest, MATERIAL_ELEMENTS, OBJECT_ATTRIBUTES};
use super::{Ctx, R};
use crate::scene::model::*;
use crate::scene::shape::{primitive_names, MESH_NAME};
use roxmltree::{Attribute, Node as XNode};
use std::collections::HashMap;

impl Ctx<'_> {
    pub(super) fn primitive(&mut self, n: XNode) -> R<Node> {
        // The shapes' names (`scene::SHAPES`) and the mesh's: "cube, cone, … or mesh".
        let names = primitive_names();
        let expected = crate::units::listed(&names, "or");
        let name_attr = self.req_attr(n, "name", OBJECT_ATTRIBUTES, &expected)?;
        let pname = name_attr.value().trim();
        let shape = match (Shape::canonical(pname), pname) {
            (Some(shape), _) => shape,
            (None, MESH_NAME) => {
                self.check_attrs(n, OBJECT_ATTRIBUTES);
                let mf = Self::attr(n, "meshfile");
                let f = Self::attr(n, "filename");
                let file = match (mf, f) {
                    (Some(a), Some(_)) => {
                        let msg = "mesh has both meshfile= and filename=; using meshfile".to_string();
                        self.warn(self.nloc(n), msg);
                        a
                    }
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => {
                        return Err(self.err(
                            self.nloc(n),
                            "a mesh primitive needs meshfile=\"file.obj\" (or filename=)".to_string(),
                        ))
                    }
                };
                self.mesh_shape(&file)
            }
            (None, other) => {
                let hint = match suggest(other, &names) {
                    Some(s) => format!("; did you mean \"{s}\"?"),
                    None => String::new(),
                };
                return Err(self.err(
                    self.aloc(&name_attr),
                    format!("unknown primitive {} (expected {expected}{hint})", shown(other)),
                ));
            }
        };
        if !matches!(shape, Shape::Mesh { .. }) {
            self.check_attrs(n, &["type", "name"]);
        }
        let material = self.material(n)?;
        Ok(Node::Primitive { shape, material, loc: self.nloc(n) })
    }

    /// A mesh's OBJ file, looked for as a texture's image is (each name
    /// once); not found, flatten() says so, as an error.
    fn mesh_shape(&mut self, a: &Attribute) -> Shape {
        let file = a.value().to_string();
        let key = ("mesh".to_string(), file.clone());
        let (resolved, warning) = match self.images.get(&key) {
            Some(known) => known.clone(),
            None if file.trim().is_empty() => (None, None),
            None => {
                let (found, note) = self.lookup("object", &file);
                // Not found: flatten()'s error says so; a note is kept only with a file found.
                let looked_up = (found.clone(), note.filter(|_| found.is_some()));
                self.images.insert(key, looked_up.clone());
                looked_up
            }
        };
        if let Some(msg) = warning {
            self.warn(self.aloc(a), msg);
        }
        Shape::Mesh { file, resolved }
    }

    fn material(&mut self, n: XNode) -> R<Material> {
        let mut m = Material::default();
        let mut seen = HashMap::new();
        for c in self.elements(n) {
            match c.tag_name().name() {
                "diffuse" => m.diffuse = self.rgb(c)?,
                "ambient" => m.ambient = self.rgb(c)?,
                "specular" => m.specular = self.rgb(c)?,
                "reflective" => m.reflective = self.rgb(c)?,
                "transparent" => m.transparent = self.rgb(c)?,
                "emissive" => m.emissive = self.rgb(c)?,
                "shininess" => m.shininess = self.v32(c)?,
                "ior" => m.ior = self.ior(c)?,
                "blend" => m.blend = self.v32(c)?,
                "texture" => m.texture = Some(self.texture(c, true)?),
                "bumpmap" => {
                    // Kept (gen writes it back), but its image is not looked
                    // for: a warning that it is missing would advise
                    // --assets for a picture that is never used.
                    m.bumpmap = Some(self.texture(c, false)?);
                    self.warn(self.nloc(c), "raycast does no bump mapping; <bumpmap> is ignored".to_string());
                }
                _ => {
                    self.unknown_element(c, "object", MATERIAL_ELEMENTS);
                    continue;
                }
            }
            self.dup(&mut seen, c, "object");
        }
        Ok(m)
    }

    /// `<texture>` or `<bumpmap>`; its image looked for when `look_up`.
    fn texture(&mut self, n: XNode, look_up: bool) -> R<TextureRef> {
        const TEXTURE: &[&str] = &["file", "u", "v"];
        self.check_attrs(n, TEXTURE);
        self.leaf(n);
        let el = n.tag_name().name();
        let fa = self.req_attr(n, "file", TEXTURE, "file=\"path/to/image.png\"")?;
        let file = fa.value().to_string();
        let u = self.opt_num(n, "u")?.unwrap_or(1.0);
        let v = self.opt_num(n, "v")?.unwrap_or(1.0);
        let repeat_u = self.to_f32(n, "u", u)?;
        let repeat_v = self.to_f32(n, "v", v)?;
        let loc = self.nloc(n);
        let resolved = if self.opts.skip_textures || !look_up {
            None
        } else if file.trim().is_empty() {
            let msg = format!("<{el}> has an empty file=: name the image, or render with --no-textures");
            self.warn(self.aloc(&fa), msg);
            None
        } else {
            self.resolve(el, &file, &loc)
        };
        Ok(TextureRef { file, resolved, repeat_u, repeat_v, loc })
    }
}
