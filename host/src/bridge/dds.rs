//! Live ROS 2: every skin's messages published over DDS by RustDDS (through `ros2-client`),
//! so a stock ROS 2 node (any RMW speaking standard DDS: Cyclone DDS, Fast DDS) subscribes
//! without a package of ours and without a ROS installation on this side.
//!
//! Topics are those of [`crate::ros2`], in DDS as ROS 2 names them (`rt/vistaf/<serial>/wrench`,
//! type `geometry_msgs::msg::dds_::WrenchStamped_`). QoS: the skin's data streams are
//! sensor data (best effort, volatile, keep last 5: a late sample is worth less than the
//! next one); `/diagnostics` is reliable, volatile, keep last 10, as ROS 2 tools expect.

use std::collections::BTreeMap;

use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher,
    QosProfile,
};

use super::Sink;
use crate::error::HostError;
use crate::ros2::{AnyMsg, Outgoing};

/// Publishes on DDS.
pub struct DdsSink {
    node: Node,
    publishers: BTreeMap<String, Publisher<AnyMsg>>,
    published: u64,
    failed: u64,
}

impl std::fmt::Debug for DdsSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DdsSink")
            .field("topics", &self.publishers.keys().collect::<Vec<_>>())
            .field("published", &self.published)
            .finish_non_exhaustive()
    }
}

fn ros2_error(what: &str, e: impl std::fmt::Debug) -> HostError {
    HostError::Ros2 {
        detail: format!("{what}: {e:?}"),
    }
}

/// The QoS of `topic`: diagnostics reliable, the skin's streams sensor data.
fn qos_of(topic: &str) -> QosProfile {
    let base = QosProfile::publisher_default().durability(Durability::Volatile);
    if topic == "/diagnostics" {
        base.reliability(Reliability::Reliable {
            when_full: WhenFull::DEFAULT,
        })
        .history(History::KeepLast { depth: 10 })
    } else {
        base.reliability(Reliability::BestEffort)
            .history(History::KeepLast { depth: 5 })
    }
}

/// The domain `ROS_DOMAIN_ID` says: 0 when unset or empty, else 0–232 (what DDS's port
/// mapping allows).
fn domain_id(var: Option<&str>) -> Result<u16, HostError> {
    match var.map(str::trim) {
        None | Some("") => Ok(0),
        Some(v) => v.parse::<u16>().ok().filter(|d| *d <= 232).ok_or_else(|| {
            ros2_error(
                "ROS_DOMAIN_ID",
                format!("{v:?} is not a domain from 0 to 232"),
            )
        }),
    }
}

/// `package/msg/Type` as a ROS 2 message type name.
fn type_name(full: &str) -> Option<MessageTypeName> {
    let mut parts = full.split('/');
    let (pkg, _msg, ty) = (parts.next()?, parts.next()?, parts.next()?);
    Some(MessageTypeName::new(pkg, ty))
}

impl DdsSink {
    /// A ROS 2 node `/vistaf/bridge_<pid>` on the DDS domain `ROS_DOMAIN_ID` names, as
    /// every ROS 2 node takes it (0 when unset).
    pub fn new() -> Result<DdsSink, HostError> {
        let domain = domain_id(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
        let context = Context::with_options(ContextOptions::new().domain_id(domain))
            .map_err(|e| ros2_error("starting DDS", e))?;
        let name = NodeName::new("/vistaf", &format!("bridge_{}", std::process::id()))
            .map_err(|e| ros2_error("node name", e))?;
        let node = context
            .new_node(name, NodeOptions::new())
            .map_err(|e| ros2_error("creating the node", e))?;
        Ok(DdsSink {
            node,
            publishers: BTreeMap::new(),
            published: 0,
            failed: 0,
        })
    }

    /// Messages published, and those DDS refused.
    pub fn counts(&self) -> (u64, u64) {
        (self.published, self.failed)
    }

    fn publisher(&mut self, msg: &Outgoing) -> Result<&Publisher<AnyMsg>, HostError> {
        if !self.publishers.contains_key(&msg.topic) {
            let (namespace, base) = match msg.topic.rsplit_once('/') {
                Some(("", base)) => ("/", base),
                Some((ns, base)) => (ns, base),
                None => ("/", msg.topic.as_str()),
            };
            let name = Name::new(namespace, base).map_err(|e| ros2_error(&msg.topic, e))?;
            let ty = type_name(msg.type_name)
                .ok_or_else(|| ros2_error(msg.type_name, "not package/msg/Type"))?;
            let topic = self
                .node
                .create_topic(&name, ty, &qos_of(&msg.topic))
                .map_err(|e| ros2_error(&msg.topic, e))?;
            let publisher = self
                .node
                .create_publisher::<AnyMsg>(&topic, None)
                .map_err(|e| ros2_error(&msg.topic, e))?;
            self.publishers.insert(msg.topic.clone(), publisher);
        }
        self.publishers
            .get(&msg.topic)
            .ok_or_else(|| ros2_error(&msg.topic, "no publisher"))
    }
}

impl Sink for DdsSink {
    /// A sample DDS refuses (a reliable reader's queue full past its blocking time) is
    /// counted, not fatal: the next summary follows within a frame.
    fn ros(&mut self, msg: &Outgoing) -> Result<(), HostError> {
        let published = self.publisher(msg)?.publish(msg.msg.clone()).is_ok();
        if published {
            self.published += 1;
        } else {
            self.failed += 1;
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), HostError> {
        eprintln!(
            "ROS 2: {} messages published on {} topics, {} refused",
            self.published,
            self.publishers.len(),
            self.failed
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_domain_is_read_as_ros_2_reads_it() {
        assert_eq!(domain_id(None).unwrap(), 0);
        assert_eq!(domain_id(Some(" 42 ")).unwrap(), 42);
        let err = domain_id(Some("300")).unwrap_err().to_string();
        assert!(
            err.contains("ROS_DOMAIN_ID") && err.contains("300"),
            "{err}"
        );
        assert!(domain_id(Some("x")).is_err());
    }

    #[test]
    fn type_names_split_into_package_and_type() {
        assert!(type_name("geometry_msgs/msg/WrenchStamped").is_some());
        assert!(type_name("WrenchStamped").is_none());
    }
}
