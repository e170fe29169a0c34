//! The MuJoCo runtime links and loads a Gymnasium task file.
#[test]
fn loads_hopper() {
    let dir = env!("DEFENDER_GYM_ASSETS");
    let model = mujoco_rs::prelude::MjModel::from_xml(format!("{dir}/hopper.xml")).unwrap();
    let mut data = model.make_data();
    data.step();
}
