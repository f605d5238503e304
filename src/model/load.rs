//! Reading and compiling a model file, alone or with artifact models
//! merged into it.

use std::path::{Path, PathBuf};

use crate::error::Result;
use crate::model::{compile, Model};
use crate::parse::osim::ModelSpec;

/// Read and compile a model file.
pub fn load_model(path: &Path) -> Result<(ModelSpec, Model)> {
    let spec = ModelSpec::read(path)?;
    let model = compile(&spec)?;
    Ok((spec, model))
}

/// Read a model file, merge the artifact models into it (in order, before
/// compilation, so that force elements of the model, of the artifacts and of
/// force-set files can all name bodies of either) and compile the result.
pub fn load_composed_model(path: &Path, artifact_files: &[PathBuf]) -> Result<(ModelSpec, Model)> {
    let spec = crate::parse::compose::read_composed(path, artifact_files)?;
    let model = compile(&spec)?;
    Ok((spec, model))
}
